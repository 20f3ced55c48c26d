"""The local Ray instance a training run started, noted in its run folder, so that the next start
in that folder ends what a SIGKILLed run left running, and nothing else.

When the driver of a local Ray is SIGKILLed, GCS, raylet and workers die with it (Ray ties them to
the driver's life), but Ray 2.60's dashboard and runtime-env agents live on, orphaned, one pair per
kill. `record` writes the session folder and the driver's pid and start time to
`<run>/ray_session.json`; `reap`, before the next start in that folder, ends the processes of
that session once its driver is gone. A process belongs to the session if it holds a file open
in the session folder (every Ray process keeps its logs there), so other Ray instances on the
machine (another run, a long campaign) are never touched. A driver that is still alive means the
run is still going: a second start in its folder is refused, and `train --stop` finds the driver
to ask (launch/packing.py). A run on a cluster notes its driver alone: the cluster's processes
are not the run's to end.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import time
from pathlib import Path

SESSION_FILE = "ray_session.json"
PROC = Path("/proc")


def _start_time(pid: int) -> str | None:
    """The process's start time in clock ticks since boot (tells a pid's reuse apart), or None
    if there is no such process, or only its exit status is left (a zombie its parent has not
    waited for)."""
    try:
        stat = (PROC / str(pid) / "stat").read_text()
    except OSError:
        return None
    fields = stat.rsplit(")", 1)[1].split()  # counted after the command name
    return None if fields[0] == "Z" else fields[19]  # fields 3 (state) and 22


def record(run_dir: Path, cluster: bool = False) -> None:
    """Note this process, the run's driver, in `run_dir` (made if missing), with the local Ray
    instance it started, or none where it joined a `cluster`."""
    session_dir = None
    if not cluster:
        import ray

        session_dir = ray._private.worker._global_node.get_session_dir_path()  # not public API
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    note = {"session_dir": session_dir, "driver_pid": os.getpid(),
            "driver_start": _start_time(os.getpid())}
    temp = run_dir / f".{SESSION_FILE}.tmp"
    temp.write_text(json.dumps(note))
    os.replace(temp, run_dir / SESSION_FILE)


def session_processes(session_dir: str) -> list[int]:
    """The pids of processes other than this one that belong to the session: a file open in
    its folder (every Ray process logs there) or the folder on the command line (an agent that
    has not opened its logs yet). Exited ones whose parent has not reaped them are left out."""
    prefix = session_dir.rstrip("/") + "/"
    found = []
    for entry in PROC.iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            if (entry / "stat").read_text().rsplit(")", 1)[1].split()[0] == "Z":
                continue
            command = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            if session_dir in command:
                found.append(int(entry.name))
                continue
            targets = [os.readlink(fd) for fd in (entry / "fd").iterdir()]
        except OSError:  # gone meanwhile, or not ours to inspect
            continue
        if any(target.startswith(prefix) for target in targets):
            found.append(int(entry.name))
    return sorted(found)


def _note(run_dir: Path, attempts: int = 10) -> dict | None:
    """The run folder's note, or None if it has none (a new run, or one on a cluster). Read
    again if it is cut short: Tune copies the run folder it restored into its own staging folder
    and syncs that back over the note, in place, every few seconds."""
    for _ in range(attempts):
        try:
            note = json.loads((Path(run_dir) / SESSION_FILE).read_text())
            return {key: note[key] for key in ("session_dir", "driver_pid", "driver_start")}
        except FileNotFoundError:
            return None
        except (OSError, ValueError, KeyError, TypeError):
            time.sleep(0.05)
    return None


def live_driver(run_dir: Path) -> int | None:
    """The pid of the driver training in `run_dir` now, if one is."""
    note = _note(run_dir)
    return note["driver_pid"] if note is not None and _alive(note) else None


def _alive(note: dict) -> bool:
    """Whether the noted driver still runs (the pid alone could be another process's by now;
    its start time tells)."""
    started = note["driver_start"]
    return started is not None and _start_time(note["driver_pid"]) == started


def reap(run_dir: Path) -> list[int]:
    """End the Ray processes left by the run last started in `run_dir` if its driver is gone,
    and drop its note; returns their pids. ValueError if that driver is still running."""
    path = Path(run_dir) / SESSION_FILE
    note = _note(run_dir)
    if note is None:
        return []
    session_dir, pid = note["session_dir"], note["driver_pid"]
    if _alive(note):
        raise ValueError(f"{Path(run_dir).resolve()}: a run (pid {pid}) is still training in "
                         f"this folder; stop it first")
    if not (isinstance(session_dir, str) and os.path.isabs(session_dir)
            and Path(session_dir).name.startswith("session_")):
        path.unlink(missing_ok=True)  # a run on a cluster, or no Ray session folder:
        return []  # nothing here is safe to end
    orphans = session_processes(session_dir)
    for orphan in orphans:
        with contextlib.suppress(ProcessLookupError, PermissionError):  # gone, or not ours
            os.kill(orphan, signal.SIGKILL)
    path.unlink()
    return orphans
