"""Carrying a run to another machine: stop it right after a checkpoint, then pack its folder.

`pack_run`, with the run stopped, folds each trial's results into a small `history.csv` (the
curve and summary columns), keeps only the newest whole checkpoint of the run, and drops Tune's
growing logs and Tune's pickled state (`TUNE_STATE`: a run resumes from its data, never from
it), so the folder (a few MB plus the stage checkpoints) can be committed, copied to a fresh
clone anywhere and resumed there with `train --resume` (`training.py`), which rebuilds every
object and path the run needs from the curriculum on the new machine.
`stop_run` stops a run training in another process with every iteration it finished in a
checkpoint: it asks the run's driver through a file in the run folder (`STOP_REQUEST`).
"""

from __future__ import annotations

import os
import shutil
import signal
import time
from pathlib import Path

from ..curriculum.curriculum import RUN_CURRICULUM_FILE
from ..runs.checkpoints import (
    checkpoint_age,
    checkpoint_complete,
    checkpoint_iteration,
    trial_dirs,
)
from ..runs.history import HISTORY_FILE, number, read_rows, read_trial, write_summary
from . import ray_session

STOP_REQUEST = "stop_request"  # in the run folder: `stop_run` asks the driver to stop
# What Tune pickles into a run folder, code paths and all; a packed run holds none of it.
TUNE_STATE = ("experiment_state-*.json", "basic-variant-state-*.json", "tuner.pkl",
              "*/params.pkl")
# A trial's logs that its history.csv replaces once packed.
TRIAL_LOGS = ("result.json", "progress.csv", "events.out.tfevents.*")


def stop_run(out: Path, say=print, poll: float = 0.5, timeout: float = 600.0) -> Path:
    """Stop the run training in `out` with every iteration it finished in a checkpoint, wait for
    it to exit and say where it stopped. The request (`STOP_REQUEST`) is taken by the driver's
    Tune callback (`tune_callbacks.StopOnRequest`): the iteration under way ends, is checkpointed,
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
    logged = [number(row.get("training_iteration"))
              for row in read_rows(checkpoint.parent, whole_run=False)]
    last = int(max((n for n in logged if n == n), default=iteration))
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


def has_run(out: Path) -> bool:
    """Whether `out` holds a run: its curriculum note, or a trial folder."""
    return (Path(out) / RUN_CURRICULUM_FILE).is_file() or bool(trial_dirs(out))


def newest_checkpoint(out: Path) -> Path | None:
    """The newest whole checkpoint of any trial of the run in `out` (by iteration), or None."""
    newest = max(_checkpoints(Path(out).resolve()), key=checkpoint_age, default=None)
    return newest if newest is not None and checkpoint_complete(newest) else None


def pack_run(out: Path) -> Path | None:
    """Shrink the stopped run in `out` to what resuming and the report need (see above), after
    ending the Ray processes a killed run left (so its note, `ray_session.json`, goes too); safe
    to repeat, refused while the run is training. Returns the checkpoint it kept, the newest
    whole one (None if there is none)."""
    out = Path(out).resolve()
    if not has_run(out):
        raise ValueError(f"--pack: no run in {out}")
    try:  # a run still training is refused; what a killed one left running is ended
        ray_session.reap(out)
    except ValueError as exc:
        raise ValueError(f"--pack: {exc}") from None
    kept = newest_checkpoint(out)
    for trial in trial_dirs(out):
        write_summary(read_trial(trial, whole_run=False), trial, HISTORY_FILE)
        stale = [*(p for pattern in TRIAL_LOGS for p in trial.glob(pattern)),
                 *(c for c in trial.glob("checkpoint_*") if c != kept)]
        for path in stale:
            if path.is_dir():
                shutil.rmtree(path)
            elif path.exists():
                path.unlink()
    for pattern in TUNE_STATE:
        for stale in out.glob(pattern):
            stale.unlink()
    return kept
