"""Tune's saved experiment state, made to name the one checkpoint a packed run keeps and to save
itself as often as the code now asks.

Tune resumes a trial from the checkpoint its experiment state registered last, and names the
trial's next checkpoints from a counter kept in the same state. Neither need agree with the
folder. A run stopped between the trial writing a checkpoint and the driver registering it
leaves a newer checkpoint the state does not name: packing keeps the newer, and the resume would
fail on the missing older one. And the counter can lag the names on disk, so a resumed trial
writes names it already holds, and evicting the checkpoint it resumed from deletes whatever now
sits under that name (both seen in a campaign: docs/measurements.md).

`register_only` rewrites the newest state file so that each packed trial has exactly the kept
checkpoint registered, with the results of its iteration, and a counter that continues after
its number. It goes through Tune's own serialisation of trials (`Trial.from_json_state` /
`get_json_state`), so only two attributes of Tune's private checkpoint bookkeeping are named
here; ray is pinned to 2.60 in pyproject.toml and tests/rl/test_resume.py resumes a packed run
whose state named an older checkpoint.

`set_snapshot_period`: Tune restores its controller's attributes from the state, the period of
its own state saves among them, so a resumed run saves as often as its first start said, whatever
`TUNE_GLOBAL_CHECKPOINT_S` says now: a run started under period 0 would save its state and copy
its result files every half second through every resume, a few percent of a core.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from ray.train import Checkpoint
from ray.train._internal.session import _TrainingResult
from ray.tune.experiment.trial import Trial

EXPERIMENT_STATE = "experiment_state-*.json"
STATE_PATTERNS = (EXPERIMENT_STATE, "basic-variant-state-*.json")  # one pair per start
CHECKPOINT_NUMBER = re.compile(r"checkpoint_(\d+)$")


def register_only(out: Path, kept: dict[str, tuple[Path, dict]]) -> dict[str, str | None]:
    """Make `kept` ({trial folder name: (checkpoint folder, its iteration's results)}) the only
    registered checkpoint of each of those trials in the newest experiment state of `out`.
    Returns, per trial of the state, the checkpoint name it had registered before."""
    path, state = _newest_state(out)
    before = {}
    for entry, (trial_json, metadata_json) in enumerate(state["trial_data"]):
        trial = _trial(trial_json, metadata_json)
        name = trial.storage.trial_dir_name
        manager = trial.run_metadata.checkpoint_manager
        latest = manager.latest_checkpoint_result
        before[name] = Path(latest.checkpoint.path).name if latest else None
        if name not in kept:
            continue
        checkpoint, metrics = kept[name]
        number = CHECKPOINT_NUMBER.search(checkpoint.name)
        if not number:
            raise ValueError(f"{checkpoint}: not a Tune checkpoint folder (checkpoint_NNNNNN)")
        # Under the trial path the state holds, which Tune rewrites when the run has moved.
        where = f"{trial.storage.trial_fs_path}/{checkpoint.name}"
        result = _TrainingResult(
            checkpoint=Checkpoint(where, filesystem=trial.storage.storage_filesystem),
            metrics=metrics)
        manager._checkpoint_results = [result]
        manager._latest_checkpoint_result = result
        trial.storage.current_checkpoint_index = int(number.group(1))
        trial.stub = json.loads(trial_json)["stub"]  # read as a stub: no trainable needed here
        trial.invalidate_json_state()
        trial.run_metadata.invalidate_cache()
        state["trial_data"][entry] = list(trial.get_json_state())
    _write_state(path, state)
    return before


def set_snapshot_period(out: Path, period: str) -> None:
    """Make the newest experiment state of `out` resume with Tune saving itself every `period`
    seconds (module docstring); the value as `TUNE_GLOBAL_CHECKPOINT_S` takes it."""
    path, state = _newest_state(out)
    state["runner_data"]["_checkpoint_period"] = period
    _write_state(path, state)


def _write_state(path: Path, state: dict) -> None:
    temp = path.with_name(f".{path.name}.tmp")  # a kill mid-write leaves the old state whole
    temp.write_text(json.dumps(state))
    os.replace(temp, path)


def _newest_state(out: Path) -> tuple[Path, dict]:
    newest = max(Path(out).glob(EXPERIMENT_STATE), default=None)
    if newest is None:
        raise ValueError(f"{out}: no Tune experiment state ({EXPERIMENT_STATE})")
    return newest, json.loads(newest.read_text())


def _trial(trial_json: str, metadata_json: str) -> Trial:
    trial = Trial.from_json_state(trial_json, stub=True)
    trial.restore_run_metadata(metadata_json)
    return trial
