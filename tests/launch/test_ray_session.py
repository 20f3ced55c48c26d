"""The next start in a run folder ends what the killed run's Ray left running, only that, and
refuses to start beside a run still going (no Ray needed: stand-in processes hold the files)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import pytest

from rllib_pommer.launch import ray_session


def _holding_a_file_in(folder) -> subprocess.Popen:
    """A process keeping a log file open in `folder`, as every Ray process of a session does."""
    (folder / "logs").mkdir(parents=True, exist_ok=True)
    log = folder / "logs" / "agent.log"
    return subprocess.Popen([sys.executable, "-c", f"f = open({str(log)!r}, 'a'); "
                             "import time; time.sleep(60)"])


def _note(run_dir, session_dir, pid, started) -> None:
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / ray_session.SESSION_FILE).write_text(json.dumps(
        {"session_dir": str(session_dir), "driver_pid": pid, "driver_start": started}))


def _wait_until_listed(session_dir, pid) -> None:
    deadline = time.monotonic() + 10
    while pid not in ray_session.session_processes(str(session_dir)):
        assert time.monotonic() < deadline, "the stand-in never opened its file"
        time.sleep(0.05)


def test_orphans_of_a_dead_driver_are_ended_and_no_one_else(tmp_path):
    ours, theirs = tmp_path / "ray" / "session_killed_1", tmp_path / "ray" / "session_other_2"
    orphan, bystander = _holding_a_file_in(ours), _holding_a_file_in(theirs)
    try:
        _wait_until_listed(ours, orphan.pid)
        _wait_until_listed(theirs, bystander.pid)
        driver = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                                capture_output=True, text=True)  # a driver that is gone
        _note(tmp_path / "run", ours, int(driver.stdout), "12345")
        assert ray_session.reap(tmp_path / "run") == [orphan.pid]
        assert orphan.wait(timeout=10) == -9
        assert bystander.poll() is None
        assert not (tmp_path / "run" / ray_session.SESSION_FILE).exists()
        assert ray_session.reap(tmp_path / "run") == []  # nothing noted any more
    finally:
        for process in (orphan, bystander):
            process.kill()
            process.wait()


def test_a_run_still_going_in_the_folder_is_not_touched(tmp_path):
    session = tmp_path / "ray" / "session_live_3"
    process = _holding_a_file_in(session)
    try:
        _wait_until_listed(session, process.pid)
        _note(tmp_path / "run", session, os.getpid(), ray_session._start_time(os.getpid()))
        with pytest.raises(ValueError, match=f"a run \\(pid {os.getpid()}\\) is still training"):
            ray_session.reap(tmp_path / "run")
        assert process.poll() is None
    finally:
        process.kill()
        process.wait()


@pytest.mark.parametrize("session_dir",
                         [None, "", "/", "relative/session_x", "/tmp/not_a_session"])
def test_a_note_that_names_no_session_folder_ends_nothing(tmp_path, session_dir):
    _note(tmp_path / "run", session_dir, 2**22 + 1, "1")
    assert ray_session.reap(tmp_path / "run") == []
    assert not (tmp_path / "run" / ray_session.SESSION_FILE).exists()


def test_a_run_on_a_cluster_notes_its_driver_alone(tmp_path):
    """A driver that joined a cluster notes itself and no session (the cluster's processes are
    not the run's): a second start beside it is refused, and once it is gone the note goes,
    ending nothing."""
    ray_session.record(tmp_path / "run", cluster=True)
    note = json.loads((tmp_path / "run" / ray_session.SESSION_FILE).read_text())
    assert note["session_dir"] is None and note["driver_pid"] == os.getpid()
    assert ray_session.live_driver(tmp_path / "run") == os.getpid()
    with pytest.raises(ValueError, match=f"a run \\(pid {os.getpid()}\\) is still training"):
        ray_session.reap(tmp_path / "run")
    assert (tmp_path / "run" / ray_session.SESSION_FILE).exists()
