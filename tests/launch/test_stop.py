"""`train --stop` stops a run with every iteration it finished in a checkpoint and says where:
a run of ours takes the request after the iteration under way (a real test-sized run), and a
driver that ignores it (a stand-in without Ray, as a run whose Tune callbacks predate the
request) is interrupted right after its next checkpoint; an iteration it still finishes after
that checkpoint is reported as lost."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

from rllib_pommer.launch.packing import STOP_REQUEST, stop_run
from rllib_pommer.runs.checkpoints import ALGORITHM_STATE, MODULE_STATE, checkpoint_iteration

REPO = Path(__file__).resolve().parents[2]

# A driver that knows nothing of stop requests: one iteration every PERIOD seconds, a whole
# checkpoint every third, and on SIGINT (as Tune on Ctrl-C) it ends at once, or with LATE it
# logs one more iteration first.
STAND_IN = textwrap.dedent("""
    import json, os, pickle, signal, sys, time
    from pathlib import Path
    from rllib_pommer.launch import ray_session

    out, period, late = Path(sys.argv[1]), float(sys.argv[2]), sys.argv[3] == "late"
    ALGORITHM_STATE, MODULE_STATE = sys.argv[4:6]
    trial = out / "PPO_stand_in"
    trial.mkdir(parents=True)
    (trial / "params.json").write_text("{}")
    note = {"session_dir": "/nonexistent/session_x", "driver_pid": os.getpid(),
            "driver_start": ray_session._start_time(os.getpid())}
    (out / ray_session.SESSION_FILE).write_text(json.dumps(note))
    iteration, interrupted = 0, []
    signal.signal(signal.SIGINT, lambda *_: interrupted.append(1))

    def log():
        global iteration
        iteration += 1
        with open(trial / "result.json", "a") as f:
            f.write(json.dumps({"training_iteration": iteration}) + "\\n")

    while not interrupted:
        time.sleep(period)
        if interrupted:
            break
        log()
        if iteration % 3 == 0:
            checkpoint = trial / f"checkpoint_{iteration // 3 - 1:06d}"
            (checkpoint / MODULE_STATE).parent.mkdir(parents=True)
            (checkpoint / "rllib_checkpoint.json").write_text("{}")
            (checkpoint / ALGORITHM_STATE).write_bytes(
                pickle.dumps({"training_iteration": iteration}))
            (checkpoint / MODULE_STATE).write_bytes(pickle.dumps({}))
    if late:
        log()
""")


def _stand_in(out: Path, late: bool, period: float = 0.6) -> subprocess.Popen:
    process = subprocess.Popen([sys.executable, "-c", STAND_IN, str(out), str(period),
                                "late" if late else "prompt", ALGORITHM_STATE, str(MODULE_STATE)],
                               cwd=REPO)
    deadline = time.monotonic() + 120
    while not (out / "ray_session.json").is_file():
        assert process.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    return process


def _last_logged(out: Path) -> int:
    (results,) = out.glob("*/result.json")
    return json.loads(results.read_text().splitlines()[-1])["training_iteration"]


def test_a_driver_that_ignores_the_request_is_interrupted_after_its_next_checkpoint(tmp_path):
    out = tmp_path / "run"
    process = _stand_in(out, late=False)
    said = []
    try:
        checkpoint = stop_run(out, say=said.append, poll=0.05)
        assert process.wait(timeout=10) == 0
    finally:
        process.kill()
    iteration = checkpoint_iteration(checkpoint)
    assert iteration == 3 == _last_logged(out)  # nothing finished after the checkpoint
    assert said[-1] == f"{out}: stopped after PPO_stand_in/{checkpoint.name} (iteration 3)"
    assert not (out / STOP_REQUEST).exists()


def test_iterations_finished_after_the_checkpoint_are_reported(tmp_path):
    out = tmp_path / "run"
    process = _stand_in(out, late=True)
    said = []
    try:
        stop_run(out, say=said.append, poll=0.05)
    finally:
        process.kill()
    assert said[-1].endswith("(iteration 3); iteration 4 finished after it, in no checkpoint: "
                             "--resume goes on from iteration 3")


def test_a_run_stops_with_its_last_iteration_checkpointed(tmp_path, pi_weights):
    """A run checkpointing every third iteration: `--stop` mid-way ends it at the iteration
    under way, checkpointed, and says so; the command exits 130 as on Ctrl-C, and nothing of
    the request is left behind."""
    curriculum = tmp_path / "every_third.toml"
    smoke = (REPO / "curriculum" / "smoke.toml").read_text()
    curriculum.write_text(smoke.replace("checkpoint_every = 1", "checkpoint_every = 3")
                          .replace('opponent = "static"\nepisodes = 12',
                                   'opponent = "static"\nepisodes = 100000'))
    out = tmp_path / "run"
    process = subprocess.Popen(
        [sys.executable, "-m", "rllib_pommer.train", "--curriculum", str(curriculum), "--out",
         str(out), "--pi-weights", str(pi_weights)], cwd=REPO, stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 300
        while not list(out.glob("*/checkpoint_000000")):  # iteration 3: well under way
            assert process.poll() is None and time.monotonic() < deadline
            time.sleep(0.2)
        stop = subprocess.run([sys.executable, "-m", "rllib_pommer.train", "--out", str(out),
                               "--stop"], cwd=REPO, capture_output=True, text=True, timeout=300)
        assert stop.returncode == 0, stop.stderr[-2000:]
        assert process.wait(timeout=120) == 130
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    last = _last_logged(out)
    newest = max(out.glob("*/checkpoint_*"), key=checkpoint_iteration)
    assert checkpoint_iteration(newest) == last > 3
    assert stop.stdout.strip().endswith(f"stopped after {newest.parent.name}/{newest.name} "
                                        f"(iteration {last})")
    assert not (out / STOP_REQUEST).exists()
