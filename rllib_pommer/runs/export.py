"""A run's learner exported as a shipped policy, with the facts its model card needs.

`export_policy` writes the newest whole checkpoint's pi (and vf) as a policy folder beside its
policy file, with `source.json` (where it came from: run, checkpoint, iteration, curriculum, the
shipped policy pi started from, found by equal weights through `agents/registry`, and the commits
that packed the run's rows, read from git) and `history/`, the run's rows up to the checkpoint,
which the card is drawn from (`train --export`, `report --card`).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import subprocess
from pathlib import Path

import torch

from ..agents.registry import policy_names, resolve_policy
from ..curriculum.curriculum import Curriculum, run_curriculum, run_start_digest
from ..imitation.learned import load_policy_net
from ..util.digest import file_sha256
from .checkpoints import (
    ALGORITHM_STATE,
    MODULE_STATE,
    checkpoint_iteration,
    latest_checkpoint,
    load_checkpoint_net,
    load_state,
    trial_dirs,
)
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

# A history row's identity across commits (the clock is not: a pack may have repaired it).
LINEAGE_COLUMNS = ("env_runners/num_env_steps_sampled_lifetime",
                   "env_runners/num_episodes_lifetime")
VF_WEIGHTS_FILE = "vf.pt"  # an exported learner's value network


def _run_curriculum(trial: Path) -> Curriculum:
    """The curriculum a trial trained on: the one its run noted (`curriculum.run_curriculum`:
    a shipped name, or the file a user gave, whatever name that file takes)."""
    curriculum = run_curriculum(trial.parent)
    if curriculum is None:
        raise ValueError(f"{trial / 'params.json'}: names no curriculum (a run of `python -m "
                         f"rllib_pommer.train` notes it in curriculum.json)")
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
    A commit that kept the checkpoint of the commit before it changed other files of the run
    (a note in its curriculum.json) and packed nothing: it is left out. A commit without a
    history or checkpoint of the trial (an older layout) is kept."""
    ours = {number(row.get("training_iteration")): row for row in trial.rows}
    log = _git(run, "log", "--format=%h", "--", ".").split()
    iterations = [_packed_iteration(run, commit, trial.path.name) for commit in log]
    commits = []
    for k, (commit, iteration) in enumerate(zip(log, iterations, strict=True)):
        if iteration is not None and k + 1 < len(log) and iterations[k + 1] == iteration:
            continue  # the same checkpoint as the commit before: no pack
        saved = _git(run, "show", f"{commit}:./{trial.path.name}/{HISTORY_FILE}")
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
        iteration = load_state(io.BytesIO(blob), f"{commit}:{state}").get("training_iteration")
    except ValueError:
        return None
    return iteration if isinstance(iteration, int) else None


def starting_policy(run: Path, curriculum: Curriculum, exclude: str = "") -> str | None:
    """The shipped learned policy pi started from, proven by equal weights: the digest of the
    weights file the run began with, noted in its folder (`run_start_digest`), or, for runs
    started before runs noted it, where the first stage froze pi, the checkpoint kept at its end
    (`<run>/stages/1-<name>`), which holds pi as the run began. The weights file a run was
    started from may have been replaced since (`imitation` was retrained after the paper run
    started from it, `ppo_league` shipped again), so its path proves nothing. None when neither
    proof is there or no policy but `exclude` matches."""
    learned = [name for name in policy_names()
               if name != exclude and resolve_policy(name).kind == "learned"]
    digest = run_start_digest(run)
    if digest:
        return next((name for name in learned
                     if file_sha256(resolve_policy(name).file("weights")) == digest), None)
    first = curriculum.stages[0]
    stage_end = run / "stages" / f"1-{first.name}"
    if not first.freeze_pi or not (stage_end / MODULE_STATE).is_file():
        return None
    start = load_checkpoint_net(stage_end).state_dict()
    for name in learned:
        weights = load_policy_net(resolve_policy(name).file("weights")).state_dict()
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
                       "game": curriculum.game, "memory": curriculum.memory,
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
