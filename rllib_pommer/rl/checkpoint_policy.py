"""Policy kind "rllib_checkpoint": the learner module of a PPO run, played like any learned policy.

A policy file (`kind = "rllib_checkpoint"`, `checkpoint = "<path>"` relative to the file, optional
`greedy`, optional `module`) or a bare directory given as a policy name (see
`registry.resolve_policy`; `DIR@snapshot_2` names a self-play snapshot's module, rl/league.py)
names a checkpoint folder, a Tune trial folder (its latest `checkpoint_*` is used) or a run folder
holding one or more trials (the newest checkpoint among them). The module played is the learner's
unless `module` names another module of the checkpoint. The learner's pi weights are read straight
from the module's saved state, without rebuilding the RLlib module (which would want the imitation
weights it started from), into a `PommerNet`, and played as the "learned" kind is
(`learned.register_learned_kind`: the same path resolution, cache and agents).

A checkpoint folder may come from anyone, and a pickle can name any callable to run while it
loads: the module state is read by `StateUnpickler`, which builds dicts and numpy arrays and
refuses every other global, so a crafted `module_state.pkl` fails with an error instead of
running code.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import pickle
import pickletools
import subprocess
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from ..agents.registry import policy_names, resolve_policy
from ..game.constants import NUM_ACTIONS
from ..imitation.learned import load_policy_net, register_learned_kind
from ..imitation.network import PommerNet, build_net, is_radio_state
from .curriculum import Curriculum, run_curriculum
from .history import (
    HISTORY_FILE,
    POLICY_HISTORY_DIR,
    POLICY_SOURCE_FILE,
    Trial,
    legs,
    lineage,
    number,
    read_trial,
    write_summary,
)

MODULES_DIR = Path("learner_group/learner/rl_module")
MODULE_STATE = MODULES_DIR / "learner" / "module_state.pkl"
ALGORITHM_STATE = "algorithm_state.pkl"
# A history row's identity across commits (the clock is not: a pack may have repaired it).
LINEAGE_COLUMNS = ("env_runners/num_env_steps_sampled_lifetime",
                   "env_runners/num_episodes_lifetime")


VF_WEIGHTS_FILE = "vf.pt"  # an exported learner's value network
NET_OUTPUTS = {"pi": NUM_ACTIONS, "vf": 1}  # the learner module's networks (rl_module.py)


def latest_checkpoint(path: str | Path) -> Path:
    """The checkpoint folder `path` names: itself, or its newest `checkpoint_*` (one or two
    levels down, for a trial or a run folder)."""
    path = Path(path)
    if (path / MODULE_STATE).is_file():
        return path
    found = [p for p in (*path.glob("checkpoint_*"), *path.glob("*/checkpoint_*"))
             if (p / MODULE_STATE).is_file()]
    if not found:
        raise ValueError(f"{path}: no RLlib checkpoint with a learner module (looked for "
                         f"{MODULE_STATE} in it and in its checkpoint_* folders)")
    return max(found, key=checkpoint_age)


def trial_dirs(out: Path) -> list[Path]:
    """The Tune trial folders of the run in `out`: those with Tune's params.json, or with
    checkpoints alone, as a run killed before Tune first copied its files to the run folder
    leaves them (the trainer writes its checkpoints there itself)."""
    return sorted(p for p in Path(out).resolve().glob("*")
                  if (p / "params.json").is_file() or any(p.glob("checkpoint_*")))


class StateUnpickler(pickle.Unpickler):
    """Unpickles what RLlib writes for a torch module's state (an OrderedDict of numpy arrays)
    and nothing else."""

    ALLOWED = {
        ("collections", "OrderedDict"),
        ("numpy", "dtype"),
        ("numpy", "ndarray"),
        ("numpy._core.numeric", "_frombuffer"),
        ("numpy.core.numeric", "_frombuffer"),
        ("numpy._core.multiarray", "_reconstruct"),
        ("numpy.core.multiarray", "_reconstruct"),
        ("numpy._core.multiarray", "scalar"),  # in algorithm_state.pkl's metrics
        ("numpy.core.multiarray", "scalar"),
    }

    def find_class(self, module: str, name: str):
        if (module, name) not in self.ALLOWED:
            raise pickle.UnpicklingError(f"refused global {module}.{name} (a module state holds "
                                         "only dicts and numpy arrays)")
        return super().find_class(module, name)


def read_module_state(state_file: Path) -> dict:
    """The saved state of an RLlib module (or of the algorithm: `algorithm_state.pkl`), or a
    ValueError naming the file and the problem."""
    with state_file.open("rb") as f:
        return _load_state(f, state_file)


def _load_state(stream: typing.BinaryIO, name: object) -> dict:
    """A pickled state dict read by `StateUnpickler`, or a ValueError naming `name`."""
    try:
        state = StateUnpickler(stream).load()
    except (pickle.UnpicklingError, EOFError, ValueError, TypeError, AttributeError,
            IndexError) as exc:
        raise ValueError(f"{name}: not a readable module state ({exc})") from None
    if not isinstance(state, dict):
        raise ValueError(f"{name}: not a readable module state (a "
                         f"{type(state).__name__}, not a dict)")
    return state


def load_checkpoint_net(path: str | Path, part: str = "pi", module: str = "learner") -> PommerNet:
    """The learner's policy network (`part="pi"`) or value network (`"vf"`), eval mode, from a
    checkpoint, trial or run folder; `module` names another module's (a self-play snapshot).
    A TeamRadio run's networks are `RadioNet`s (they hear), a Team run's `PommerNet`s."""
    if part not in NET_OUTPUTS:
        raise ValueError(f"part must be one of {list(NET_OUTPUTS)}, got {part!r}")
    checkpoint = latest_checkpoint(path)
    state_file = checkpoint / MODULES_DIR / module / "module_state.pkl"
    if not state_file.is_file():
        found = sorted(p.parent.name for p in (checkpoint / MODULES_DIR).glob("*/module_state.pkl"))
        raise ValueError(f"{checkpoint}: no module {module!r}; its modules: {found}")
    state = read_module_state(state_file)
    weights = {str(key).removeprefix(f"{part}."): torch.as_tensor(value)
               for key, value in state.items() if str(key).startswith(f"{part}.")}
    net = build_net(NET_OUTPUTS[part], is_radio_state(weights))
    try:
        net.load_state_dict(weights)
    except (RuntimeError, TypeError) as exc:
        raise ValueError(f"{state_file}: learner {part} weights do not fit "
                         f"{type(net).__name__} ({exc})") from None
    return net.eval()


def checkpoint_iteration(checkpoint: Path) -> int:
    """The training iteration a checkpoint folder was taken at (its algorithm_state.pkl)."""
    state_file = Path(checkpoint) / ALGORITHM_STATE
    iteration = read_module_state(state_file).get("training_iteration")
    if not isinstance(iteration, int) or iteration < 1:
        raise ValueError(f"{state_file}: no training_iteration (found {iteration!r})")
    return iteration


def unreadable(path: Path) -> str | None:
    """What is wrong with a JSON or pickle file (a Tune state file, a checkpoint's parts), if
    anything: empty, cut short or malformed. A pickle is only parsed, never loaded."""
    try:
        data = path.read_bytes()
        if not data:
            return "empty"
        if data[:1] in (b"{", b"["):
            json.loads(data)
        else:
            for _ in pickletools.genops(data):
                pass
    except (OSError, ValueError) as exc:
        return str(exc)
    return None


def checkpoint_complete(checkpoint: Path) -> bool:
    """Whether a checkpoint folder holds every part whole: its metadata, the learner's module
    state, and no JSON or pickle cut short. Tune copies a checkpoint into the run folder file by
    file, so a run killed mid-copy leaves a folder with the newest iteration and not all of it;
    packing must not keep that one in place of the older whole one."""
    checkpoint = Path(checkpoint)
    required = [checkpoint / "rllib_checkpoint.json", checkpoint / ALGORITHM_STATE,
                checkpoint / MODULE_STATE]
    parts = [*checkpoint.rglob("*.pkl"), *checkpoint.rglob("*.json")]
    return all(p.is_file() for p in required) and not any(unreadable(p) for p in parts)


def checkpoint_age(path: Path) -> tuple[int, float, str]:
    """A checkpoint's (training iteration, mtime, name), to find the newest: not its number,
    which every leg of a run (each resume, rl/history.legs) starts again from 0. One that is not
    whole (`checkpoint_complete`) or cannot be read (older than algorithm states) comes first."""
    try:
        iteration = checkpoint_iteration(path) if checkpoint_complete(path) else -1
    except (ValueError, OSError):
        iteration = -1
    return iteration, path.stat().st_mtime, path.name


def _run_curriculum(trial: Path) -> Curriculum:
    """The curriculum a trial trained on: the one its run noted (`curriculum.run_curriculum`:
    a shipped name, or the file a user gave, whatever name that file takes)."""
    curriculum = run_curriculum(trial.parent)
    if curriculum is None:
        raise ValueError(f"{trial / 'params.json'}: names no curriculum (a run of `python -m "
                         f"rllib_pommer.train` records its CurriculumCallback there)")
    return curriculum


def _git(folder: Path, *args: str) -> str:
    done = subprocess.run(["git", "-C", str(folder), *args], capture_output=True, text=True)
    return done.stdout.strip() if done.returncode == 0 else ""


def _trial_of(checkpoint: Path) -> Path:
    """The trial folder whose rows and params a checkpoint belongs with: its parent, or for a
    stage's checkpoint (`<run>/stages/<n>-<name>`) the run's newest leg (history.legs), whose
    history holds the rows of every leg."""
    if (checkpoint.parent / "params.json").is_file():
        return checkpoint.parent
    trials = trial_dirs(checkpoint.parents[1])
    newest = max(trials, key=lambda trial: len(legs(trial)), default=None)
    if newest is None or len(legs(newest)) != len(trials):
        raise ValueError(f"{checkpoint}: not in a trial folder, and its run "
                         f"{checkpoint.parents[1]} has {len(trials)} trials, not the legs of "
                         f"one run")
    return newest


def packed_commits(run: Path, trial: Trial) -> list[str]:
    """The commits (newest first) that packed the rows `trial` holds: each commit of the run
    folder whose kept checkpoint's iteration has, in that commit's history of the trial, the row
    `trial.rows` has (same env steps and episodes; rows logged after that checkpoint were run
    again on resume). A run set back to an earlier pack and trained again leaves commits of rows
    it abandoned (the paper campaign's collapsed run: docs/measurements.md), and a policy
    exported before the newest pack was not trained through the later ones: both are left out.
    A commit without a history or checkpoint of the trial (an older layout) is kept."""
    ours = {number(row.get("training_iteration")): row for row in trial.rows}
    commits = []
    for commit in _git(run, "log", "--format=%h", "--", ".").split():
        saved = _git(run, "show", f"{commit}:./{trial.path.name}/{HISTORY_FILE}")
        iteration = _packed_iteration(run, commit, trial.path.name)
        theirs = [row for row in csv.DictReader(io.StringIO(saved))
                  if number(row.get("training_iteration")) == iteration]
        if theirs:
            row = ours.get(iteration)
            if row is None or any(number(row.get(c)) != number(theirs[-1].get(c))
                                  for c in LINEAGE_COLUMNS if c in theirs[-1]):
                continue
        commits.append(commit)
    return commits


def _packed_iteration(run: Path, commit: str, trial_name: str) -> int | None:
    """The iteration of the checkpoint that `commit` holds for the trial (None: none read)."""
    listed = _git(run, "ls-tree", "-r", "--name-only", commit, "--", trial_name).split()
    state = next((name for name in listed if name.endswith(f"/{ALGORITHM_STATE}")), None)
    if state is None:
        return None
    blob = subprocess.run(["git", "-C", str(run), "show", f"{commit}:./{state}"],
                          capture_output=True).stdout
    try:
        iteration = _load_state(io.BytesIO(blob), f"{commit}:{state}").get("training_iteration")
    except ValueError:
        return None
    return iteration if isinstance(iteration, int) else None


def starting_policy(run: Path, curriculum: Curriculum, exclude: str = "") -> str | None:
    """The shipped learned policy pi started from, proven by equal weights: where the first stage
    froze pi, the checkpoint kept at its end (`<run>/stages/1-<name>`) holds pi as the run began.
    The weights file a run was started from may have been replaced since (`imitation` was
    retrained after the paper run started from it), so its path proves nothing. None when the
    first stage trained pi, its checkpoint is missing, or no policy but `exclude` matches."""
    first = curriculum.stages[0]
    stage_end = run / "stages" / f"1-{first.name}"
    if not first.freeze_pi or not (stage_end / MODULE_STATE).is_file():
        return None
    start = load_checkpoint_net(stage_end).state_dict()
    for name in policy_names():
        spec = resolve_policy(name)
        if name == exclude or spec.kind != "learned":
            continue
        weights = load_policy_net(spec.file("weights")).state_dict()
        # a Team net's keys: all of a PommerNet's, and a RadioNet's but hearing and speaking
        if all(key in start and torch.equal(start[key], value) for key, value in weights.items()):
            return name
    return None


def _source(policy: str, checkpoint: Path, trial: Trial, iteration: int,
            curriculum: Curriculum) -> dict:
    """Where a policy came from, as its model card says (`viz/model_card.py`)."""
    run = checkpoint.parents[1]
    return {
        "policy": policy, "run": run.name, "trial": trial.path.name,
        "checkpoint": f"{checkpoint.parent.name}/{checkpoint.name}", "iteration": iteration,
        "curriculum": {"name": curriculum.name, "description": curriculum.description,
                       "game": curriculum.game,
                       "stages": [dataclasses.asdict(stage) for stage in curriculum.stages]},
        "exported_at_commit": _git(run, "rev-parse", "--short", "HEAD") or "unknown",
        "run_commits": packed_commits(run, trial),
        "pi_start": (start := starting_policy(run, curriculum, exclude=policy)),
        "lineage": lineage(start),
    }


def export_policy(source: str | Path, target: str | Path) -> tuple[Path, Path]:
    """Ship the learner of a checkpoint, trial or run folder as a policy like `imitation`:
    `target/pi.pt`, a plain state_dict that `torch.load(weights_only=True)` reads, its value
    network as `target/vf.pt` (for a run that continues it: a curriculum's `vf_weights`),
    `target.toml` (kind learned, sampling, as the arena plays a run folder), and what its model
    card is drawn from (`history.exported_training`; the job draws the card): the trial's rows up
    to the checkpoint and `source.json`. Existing weights or policy files are never replaced."""
    # imported here: bc loads TensorBoard and the dataset reader, the card's module matplotlib,
    # which playing a checkpoint never needs
    from ..imitation.bc import WEIGHTS_FILE, write_policy_file
    from ..viz.model_card import CARD_FILE

    checkpoint = latest_checkpoint(source).resolve()
    net = load_checkpoint_net(checkpoint)
    iteration = checkpoint_iteration(checkpoint)
    trial = read_trial(_trial_of(checkpoint))
    rows = [row for row in trial.rows if float(row["training_iteration"]) <= iteration]
    if not rows or float(rows[-1]["training_iteration"]) != iteration:
        raise ValueError(f"{trial.path}: no result row for iteration {iteration}, where "
                         f"{checkpoint.name} was taken (a run still writing? export it stopped)")
    curriculum = _run_curriculum(trial.path)
    target = Path(target)
    weights, policy_file = target / WEIGHTS_FILE, target.with_suffix(".toml")
    for path in (weights, target / VF_WEIGHTS_FILE, policy_file):
        if path.exists():
            raise ValueError(f"{path} exists; export to another name or move it aside")
    target.mkdir(parents=True, exist_ok=True)
    torch.save(net.state_dict(), weights)
    torch.save(load_checkpoint_net(checkpoint, "vf").state_dict(), target / VF_WEIGHTS_FILE)
    write_policy_file(target, f"PPO learner exported from {checkpoint.parent.name}/"
                              f"{checkpoint.name}; see {target.name}/{CARD_FILE}", greedy=False)
    write_summary(Trial(trial.path, rows), target / POLICY_HISTORY_DIR / trial.name)
    (target / POLICY_SOURCE_FILE).write_text(json.dumps(
        _source(target.name, checkpoint, Trial(trial.path, rows), iteration, curriculum),
        indent=1) + "\n")
    return weights, policy_file


def _load_checkpoint(path: Path, options: Mapping[str, Any]) -> tuple[PommerNet, Path]:
    """The network of the checkpoint's module `options["module"]` (default the learner's) and
    the module state it was read from."""
    module = options.get("module", "learner")
    return (load_checkpoint_net(path, module=module),
            latest_checkpoint(path) / MODULES_DIR / module / "module_state.pkl")


register_learned_kind("rllib_checkpoint", "checkpoint", _load_checkpoint)
