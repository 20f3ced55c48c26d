"""Carrying a run to another machine: stop it right after a checkpoint, then pack its folder.

`pack_run`, with the run stopped, folds the iterations' results into a small `history.csv` per
trial (the curve and summary columns), keeps only the newest whole checkpoint, makes it the one
Tune resumes from (`tune_state`) and drops Tune's growing logs (progress.csv down to its header),
so the folder (a few MB plus the stage checkpoints) can be committed, copied to a fresh clone
anywhere and resumed there with `train --resume` (`training.py`): Tune restores a moved
experiment, and every path the run needs is rebuilt from the curriculum on the new machine.
`stop_run` stops a run training in another process with every iteration it finished in a
checkpoint: it asks the run's driver through a file in the run folder (`STOP_REQUEST`).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import time
from pathlib import Path

from ray import tune

from . import ray_session, tune_state
from .checkpoint_policy import (
    checkpoint_age,
    checkpoint_complete,
    checkpoint_iteration,
    trial_dirs,
)
from .history import HISTORY_FILE, Trial, number, read_trial, write_summary
from .tune_state import STATE_PATTERNS

STOP_REQUEST = "stop_request"  # in the run folder: `stop_run` asks the driver to stop


def stop_run(out: Path, say=print, poll: float = 0.5, timeout: float = 600.0) -> Path:
    """Stop the run training in `out` with every iteration it finished in a checkpoint, wait for
    it to exit and say where it stopped. The request (`STOP_REQUEST`) is taken by the driver's
    Tune callback (`training.StopOnRequest`): the iteration under way ends, is checkpointed,
    and the run stops as on Ctrl-C. A driver that does not take it (one whose Tune callbacks,
    restored with the run, lack that one) is interrupted right after its next checkpoint; if it
    still finished an iteration after that checkpoint, the report says which ones are in no
    checkpoint. Returns the checkpoint the run stopped at; ValueError if no run is going in
    `out`, or it ended before a checkpoint."""
    out = Path(out).resolve()
    pid = ray_session.live_driver(out)
    if pid is None:
        raise ValueError(f"--stop: no run is training in {out} (no live driver noted in its "
                         f"{ray_session.SESSION_FILE})")
    request = out / STOP_REQUEST
    request.write_text(f"{os.getpid()}\n")
    say(f"{out}: stopping the run after the iteration under way (driver pid {pid})")
    try:
        _interrupt_unless_taken(out, request, pid, poll)
        deadline = time.monotonic() + timeout
        while ray_session.live_driver(out) is not None:
            if time.monotonic() > deadline:
                raise ValueError(f"--stop: the run in {out} (pid {pid}) did not exit within "
                                 f"{timeout:.0f} s of stopping")
            time.sleep(poll)
    finally:
        take_stop_request(out)
    checkpoint = max(_checkpoints(out), key=checkpoint_age, default=None)
    if checkpoint is None:
        raise ValueError(f"--stop: the run in {out} ended before its first checkpoint")
    say(f"{out}: stopped after {checkpoint.parent.name}/{checkpoint.name} (iteration "
        f"{checkpoint_iteration(checkpoint)}){_lost(checkpoint)}")
    return checkpoint


def _interrupt_unless_taken(out: Path, request: Path, pid: int, poll: float) -> None:
    """Wait until the driver takes the stop request, or exits, or writes a checkpoint without
    having taken it: then withdraw the request and interrupt the driver at once (SIGINT, as
    Ctrl-C), before it can finish another iteration. Whoever removes the request file acts on
    it, so the driver is never interrupted twice."""
    start = time.time()
    while request.exists() and ray_session.live_driver(out) is not None:
        if any(_taken_since(c, start) for c in _checkpoints(out)):
            if take_stop_request(out):
                os.kill(pid, signal.SIGINT)
            return
        time.sleep(poll)


def take_stop_request(run_dir: Path) -> bool:
    """Remove the run's stop request; whether there was one. Removing is atomic, so exactly
    one of the driver and `stop_run` takes a request."""
    try:
        (Path(run_dir) / STOP_REQUEST).unlink()
    except FileNotFoundError:
        return False
    return True


def _lost(checkpoint: Path) -> str:
    """What the report adds when the trial logged iterations after `checkpoint`: those are in
    no checkpoint, and `--resume` goes on from the checkpoint."""
    iteration = checkpoint_iteration(checkpoint)
    last = max((row["training_iteration"] for _, row in _results(checkpoint.parent / "result.json")
                if isinstance(row.get("training_iteration"), int)), default=iteration)
    if last <= iteration:
        return ""
    after = f"iteration {last}" if last == iteration + 1 else f"iterations {iteration + 1}-{last}"
    return (f"; {after} finished after it, in no checkpoint: --resume goes on from iteration "
            f"{iteration}")


def _checkpoints(out: Path) -> list[Path]:
    return [c for trial in trial_dirs(out) for c in trial.glob("checkpoint_*")]


def _taken_since(checkpoint: Path, start: float) -> bool:
    """Whether `checkpoint` is whole and was written after `start` (Tune may delete it
    meanwhile)."""
    try:
        return checkpoint.stat().st_mtime > start and checkpoint_complete(checkpoint)
    except OSError:
        return False


def pack_run(out: Path) -> dict:
    """Shrink the stopped run in `out` to what resuming and the report need (see above), after
    ending the Ray processes a killed run left (so its note, `ray_session.json`, goes too); safe
    to repeat, refused while the run is training. The newest checkpoint (by iteration) is kept
    and made the one Tune resumes from (`tune_state.register_only`). Returns what it kept:
    {trial name: (newest checkpoint name, the name Tune's state had registered)}."""
    out = Path(out).resolve()  # Tune takes a relative path for a URI without a scheme
    if not tune.Tuner.can_restore(str(out)):
        raise ValueError(f"--pack: no run in {out}")
    try:  # a run still training is refused; what a killed one left running is ended
        ray_session.reap(out)
    except ValueError as exc:
        raise ValueError(f"--pack: {exc}") from None
    newest_of, to_register = {}, {}
    for trial in trial_dirs(out):
        checkpoints = sorted(trial.glob("checkpoint_*"), key=checkpoint_age)
        summary = read_trial(trial)
        write_summary(summary, trial, HISTORY_FILE)
        results = trial / "result.json"
        rows = _results(results)
        if rows:  # Tune reads the last result when it restores the trial
            results.write_text(f"{rows[-1][0]}\n")
        _keep_header(trial / "progress.csv")
        for stale in [*checkpoints[:-1], *trial.glob("events.out.tfevents.*")]:
            if stale.is_dir():
                shutil.rmtree(stale)
            elif stale.exists():
                stale.unlink()
        newest_of[trial.name] = checkpoints[-1] if checkpoints else None
        if checkpoints:
            to_register[trial.name] = (checkpoints[-1], _result_at(
                rows, summary, checkpoint_iteration(checkpoints[-1])))
    registered = tune_state.register_only(out, to_register)
    for pattern in STATE_PATTERNS:
        for stale in sorted(out.glob(pattern))[:-1]:  # one per start; Tune reads the newest
            stale.unlink()
    return {name: (newest and newest.name, registered.get(name))
            for name, newest in newest_of.items()}


def _keep_header(progress: Path) -> None:
    """Cut Tune's progress.csv to its header line: the rows live on in history.csv, and Tune's
    CSV logger, which copies the file back from the run folder on resume, appends below it (a
    deleted file made it warn "Remote file not found" on every resume)."""
    if progress.is_file():
        with open(progress, newline="") as f:
            header = f.readline()
        progress.write_text(header if header.endswith("\n") else "")


def _results(path: Path) -> list[tuple[str, dict]]:
    """result.json's lines with what they hold; a line cut short (a killed write) is left out."""
    if not path.is_file():
        return []
    parsed = []
    for line in path.read_text().splitlines():
        try:
            parsed.append((line, json.loads(line)))
        except json.JSONDecodeError:
            continue
    return parsed


def _result_at(rows: list[tuple[str, dict]], summary: Trial, iteration: int) -> dict:
    """The result of `iteration` (the newest such line of result.json), as Tune records beside a
    checkpoint, its clock taken from the trial's summary rows (one clock over every restore,
    rl/history.py). If no line survived (a pack repeated after the first cut result.json to
    a later iteration's line, or a run killed before Tune copied its result files to the run
    folder), the iteration and its clock alone: Tune's trainable restores its iteration counter
    and clock from these metrics; from {} it would number the resumed iterations from 1 again
    (and the history, reading that as a restore, drop every row) and restart the clock at 0."""
    result = next((r for _, r in reversed(rows) if r.get("training_iteration") == iteration),
                  {"training_iteration": iteration})
    clock = next((number(row.get("time_total_s")) for row in reversed(summary.rows)
                  if number(row.get("training_iteration")) == iteration), math.nan)
    return {**result, "time_total_s": clock} if math.isfinite(clock) else result
