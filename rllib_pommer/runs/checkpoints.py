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

import json
import pickle
import pickletools
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from ..game.constants import NUM_ACTIONS
from ..imitation.learned import register_learned_kind
from ..imitation.network import PommerNet, build_net, is_radio_state, planes_of

MODULES_DIR = Path("learner_group/learner/rl_module")
MODULE_STATE = MODULES_DIR / "learner" / "module_state.pkl"
ALGORITHM_STATE = "algorithm_state.pkl"


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
        return load_state(f, state_file)


def load_state(stream: typing.BinaryIO, name: object) -> dict:
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
    net = build_net(NET_OUTPUTS[part], is_radio_state(weights), planes_of(weights))
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
    which every leg of a run (each resume, runs/history.legs) starts again from 0. One that is not
    whole (`checkpoint_complete`) or cannot be read (older than algorithm states) comes first."""
    try:
        iteration = checkpoint_iteration(path) if checkpoint_complete(path) else -1
    except (ValueError, OSError):
        iteration = -1
    return iteration, path.stat().st_mtime, path.name


def _load_checkpoint(path: Path, options: Mapping[str, Any]) -> tuple[PommerNet, Path]:
    """The network of the checkpoint's module `options["module"]` (default the learner's) and
    the module state it was read from."""
    module = options.get("module", "learner")
    return (load_checkpoint_net(path, module=module),
            latest_checkpoint(path) / MODULES_DIR / module / "module_state.pkl")


register_learned_kind("rllib_checkpoint", "checkpoint", _load_checkpoint)
