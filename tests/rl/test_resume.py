"""`python -m rllib_pommer.train --resume` continues a SIGKILLed run with stage and counters (or
refuses a broken state, never starting over), cleans up after it, and keeps the checkpoint at
the warm-up's end."""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import torch

from rllib_pommer.imitation.learned import load_policy_net
from rllib_pommer.rl import ray_session, tune_state
from rllib_pommer.rl.checkpoint_policy import (
    checkpoint_complete,
    checkpoint_iteration,
    load_checkpoint_net,
)
from rllib_pommer.rl.history import read_rows
from rllib_pommer.rl.training import SNAPSHOT_PERIOD_S

REPO = Path(__file__).resolve().parents[2]


def _train(out, pi_weights, *extra):
    weights = ["--pi-weights", str(pi_weights)] if pi_weights else []
    return [sys.executable, "-m", "rllib_pommer.train", "--curriculum", "smoke", "--out",
            str(out), *weights, *extra]


def _results(out):
    (result_file,) = out.glob("*/result.json")
    return [json.loads(line) for line in result_file.read_text().splitlines() if line]


def test_resume_after_sigkill(tmp_path, pi_weights):
    """SIGKILL the driver alone (as the OOM killer does): Ray's agents outlive it, and the
    experiment state may be left empty, or behind the checkpoints. The next start ends those
    orphans (and nothing else); `--resume` refuses the empty state with one line and exit 2
    instead of starting over; with the state back, though it names an older checkpoint or none,
    it continues from the newest checkpoint on disk."""
    out = tmp_path / "run"
    process = subprocess.Popen(_train(out, pi_weights), cwd=REPO, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        _wait_for(lambda: list(out.glob("*/checkpoint_000000")), process, 240, "a checkpoint")
        (experiment_state,) = out.glob("experiment_state-*.json")
        behind = _whole_json(experiment_state, process)  # names no checkpoint, or the first one
        _wait_for(lambda: list(out.glob("*/checkpoint_000001")), process, 240,
                  "a second checkpoint")
        time.sleep(1.0)
        assert process.poll() is None, "training ended before it could be killed"
        process.kill()
        process.wait()
        session_dir = json.loads((out / ray_session.SESSION_FILE).read_text())["session_dir"]
        time.sleep(2.0)  # Ray's processes tied to the driver die with it
        orphans = ray_session.session_processes(session_dir)
        # checkpoint_00000k is written after iteration k + 1; Tune's result files of the killed
        # run may never have left its staging area, so the checkpoints are what survived.
        checkpoints = [c for c in out.glob("*/checkpoint_*") if checkpoint_complete(c)]
        assert checkpoints
        for copied in out.glob("PPO_*/*"):  # as a kill before Tune first copied the trial's
            if copied.is_file():  # files leaves its folder: the trainer's checkpoints alone
                copied.unlink()
        newest = max(checkpoint_iteration(c) for c in checkpoints)
        experiment_state.write_bytes(behind)
        (state,) = out.glob("basic-variant-state-*.json")
        intact = state.read_bytes()
        state.write_bytes(b"")  # as a kill can leave it: Tune would start the run over
        refused = subprocess.run(_train(out, pi_weights, "--resume"), cwd=REPO,
                                 capture_output=True, text=True, timeout=120)
        assert refused.returncode == 2, refused.stderr[-2000:]
        assert f"{state.name} is unreadable (empty)" in refused.stderr
        assert "Traceback" not in refused.stderr
        assert ray_session.session_processes(session_dir) == []
        if orphans:  # Ray 2.60 leaves its dashboard and runtime-env agents (others may still
            # have been dying when they were listed)
            assert re.search(r"ended [1-9]\d* Ray processes left by the killed run",
                             refused.stderr)
        state.write_bytes(intact)
        finished = subprocess.run(_train(out, pi_weights, "--resume"), cwd=REPO,
                                  capture_output=True, text=True, timeout=300)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)  # whatever of the killed run's group is left
    assert finished.returncode == 0, finished.stderr[-2000:]
    results = _results(out)
    resumed = [r for r in results if r["iterations_since_restore"] < r["training_iteration"]]
    assert resumed, ("no iterations after a restore: the run started from scratch\n"
                     + finished.stdout[-3000:])
    first = resumed[0]
    # Continues after the newest checkpoint on disk (whichever Tune's state had caught up
    # with: the resume packs the run), with the lifetime counters it had there.
    assert first["training_iteration"] == newest + 1
    assert first["curriculum"]["episodes"] > first["env_runners"]["num_episodes"]
    final = resumed[-1]
    assert final["curriculum"]["episodes"] >= final["curriculum"]["total_episodes"]
    assert final["curriculum"]["stage_name"] == "static"
    # The warm-up's end was kept apart from the rotating checkpoints, with pi as it started.
    assert (out / "stages" / "2-static").is_dir()  # the final stage is kept too
    warmup_end = load_checkpoint_net(out / "stages" / "1-warmup").state_dict()
    start = load_policy_net(pi_weights).state_dict()
    assert all(torch.equal(warmup_end[key], start[key]) for key in start)


def _iteration(row) -> int:
    return int(float(row["training_iteration"]))


def _whole_json(path: Path, process) -> bytes:
    """`path`'s bytes once they parse: Tune may be writing the file as it is read (on a loaded
    machine the test once kept a cut-short copy, which the resume then rightly refused)."""
    copy = b""

    def parses() -> bool:
        nonlocal copy
        copy = path.read_bytes()
        try:
            json.loads(copy)
        except ValueError:  # empty or cut short
            return False
        return True

    _wait_for(parses, process, 30, f"{path.name} written whole")
    return copy


def _wait_for(predicate, process, seconds: float, what: str) -> None:
    deadline = time.monotonic() + seconds
    while not predicate():
        assert process.poll() is None, f"training ended before {what}"
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.2)


def _interrupt(process) -> int:
    process.send_signal(signal.SIGINT)  # as Ctrl-C: Tune checkpoints and the CLI exits 130
    try:
        return process.wait(timeout=120)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)


def test_a_packed_run_resumes_at_another_path(tmp_path, pi_weights):
    """Stop a run, pack it, move it to another folder (as a fresh clone would hold it) and resume
    it from another working directory, on a machine without the imitation weights it started
    from: it goes on from its newest checkpoint, same lifetime episode count and stage, its
    history reads as one run, and the arena plays it. The run is left as stops have left the
    campaign's: Tune's state older than the newest checkpoint (a stop that beat Tune to
    registering it) and the newest checkpoint numbered below an older one (a resume under stale
    numbers); the pack makes Tune resume from the newest, numbering on after it. The first run
    is stopped by `train --stop`, right after a checkpoint."""
    started_from = tmp_path / "first" / "weights" / "pi.pt"  # removed with the old place
    started_from.parent.mkdir(parents=True)
    shutil.copy(pi_weights, started_from)
    pi_weights = started_from
    scripted = tmp_path / "scripted_policies"  # a policies folder without any learned policy
    scripted.mkdir()
    for policy in ("simple", "static", "suicide"):
        shutil.copy(REPO / "policies" / f"{policy}.toml", scripted)
    elsewhere = {**os.environ, "RLLIB_POMMER_POLICIES": str(scripted)}
    curriculum = tmp_path / "long_smoke.toml"
    smoke = (REPO / "curriculum" / "smoke.toml").read_text()
    assert 'opponent = "static"\nepisodes = 12' in smoke
    curriculum.write_text(smoke.replace('opponent = "static"\nepisodes = 12',
                                        'opponent = "static"\nepisodes = 100000'))
    first = tmp_path / "first" / "run"
    process = subprocess.Popen(_train(first, pi_weights, "--curriculum", str(curriculum)),
                               cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               start_new_session=True)
    _wait_for(lambda: list(first.glob("*/checkpoint_000001")), process, 240, "2 iterations")
    (early_state,) = first.glob("experiment_state-*.json")
    early = early_state.read_bytes()
    _wait_for(lambda: list(first.glob("*/checkpoint_000002")), process, 240, "3 iterations")
    stop = subprocess.run([sys.executable, "-m", "rllib_pommer.train", "--out", str(first),
                           "--stop"], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert stop.returncode == 0 and "stopped after PPO_" in stop.stdout, stop.stderr[-2000:]
    assert process.wait(timeout=60) == 130  # it stopped as on Ctrl-C, after a checkpoint
    assert max(p.name for p in first.glob("*/checkpoint_*")) > "checkpoint_000002"
    early_state.write_bytes(early)
    (trial,) = [p for p in first.iterdir() if p.is_dir() and p.name.startswith("PPO_")]
    *_, lower, higher = sorted(trial.glob("checkpoint_*"))
    newest_iteration = checkpoint_iteration(higher)
    # An iteration logged after the checkpoint, as a stop can leave (the paper campaign at
    # 6,175/6,176): the resume packs again, and must still find the checkpoint's result, or
    # Tune restarts the clock.
    (result_file,) = first.glob("*/result.json")
    last_result = json.loads(result_file.read_text().splitlines()[-1])
    assert last_result["training_iteration"] == newest_iteration
    after_checkpoint = {**last_result, "training_iteration": newest_iteration + 1,
                        "time_total_s": last_result["time_total_s"] + 1.0}
    with open(result_file, "a") as f:
        f.write(json.dumps(after_checkpoint) + "\n")
    higher.rename(trial / "swap")
    lower.rename(higher)
    (trial / "swap").rename(lower)  # the newest now has the lower number
    packed = subprocess.run([sys.executable, "-m", "rllib_pommer.train", "--out", str(first),
                             "--pack"], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert packed.returncode == 0, packed.stderr[-2000:]
    assert f"it now resumes from {lower.name}" in packed.stdout
    assert [p.name for p in trial.glob("checkpoint_*")] == [lower.name]
    assert (trial / "history.csv").is_file() and not list(trial.glob("events.out.tfevents.*"))
    assert len((trial / "progress.csv").read_text().splitlines()) == 1  # the header, for Tune
    before = [r for r in read_rows(trial) if _iteration(r) <= newest_iteration]
    (state,) = first.glob("basic-variant-state-*.json")  # pack keeps the newest only
    intact = state.read_bytes()
    state.write_bytes(b"")  # as a kill mid-write can leave it: Tune would start over
    refused = subprocess.run(_train(first, pi_weights, "--curriculum", str(curriculum),
                                    "--resume"), cwd=REPO, capture_output=True, text=True,
                             timeout=120)
    assert refused.returncode == 2 and f"{state.name} is unreadable" in refused.stderr
    state.write_bytes(intact)
    tune_state.set_snapshot_period(first, "0")  # as the campaigns had first started
    moved = tmp_path / "clone" / "campaign" / "run"
    shutil.copytree(first, moved)
    shutil.rmtree(tmp_path / "first")  # nothing may point back to the old place
    assert not pi_weights.exists()
    resumed_log = tmp_path / "resumed.log"
    with open(resumed_log, "wb") as log:
        process = subprocess.Popen(_train(moved, None, "--curriculum", str(curriculum),
                                          "--resume"), cwd=tmp_path, stdout=subprocess.DEVNULL,
                                   stderr=log, start_new_session=True, env=elsewhere)
    moved_trial = moved / trial.name
    # one new checkpoint, then stop: Tune keeps three, so more would evict the kept one
    _wait_for(lambda: [c for c in moved_trial.glob("checkpoint_*")
                       if c.name != lower.name and checkpoint_complete(c)], process, 240,
              "a checkpoint after the resume")
    _interrupt(process)
    assert "Remote file not found" not in resumed_log.read_text()  # Tune found what it reads
    resumed_state = json.loads(max(moved.glob("experiment_state-*.json")).read_text())
    assert resumed_state["runner_data"]["_checkpoint_period"] == SNAPSHOT_PERIOD_S  # not "0"
    rows = read_rows(moved_trial)
    iterations = [_iteration(r) for r in rows]
    assert iterations == list(range(1, len(rows) + 1))  # one run, no gap, no restart
    assert _iteration(rows[len(before)]) == newest_iteration + 1  # from the newest
    assert checkpoint_iteration(moved_trial / lower.name) == newest_iteration  # not overwritten
    after = sorted(moved_trial.glob("checkpoint_*"))
    assert after[0].name == lower.name and len(after) > 1  # new ones numbered after the kept
    assert [checkpoint_iteration(c) for c in after] == sorted(map(checkpoint_iteration, after))
    last, resumed = before[-1], rows[len(before)]
    lifetime = int(float(last["env_runners/num_episodes_lifetime"]))
    assert (resumed["env_runners/num_episodes_lifetime"] - resumed["env_runners/num_episodes"]
            == lifetime > 12)  # past the warm-up's 12 episodes: in the second stage
    assert resumed["curriculum/iteration_stage_name"] == last[
        "curriculum/iteration_stage_name"] == "static"
    # Tune's own clock went on from the checkpoint's (not from 0), before any repair on reading.
    restored = next(r for r in _results(moved) if r["iterations_since_restore"] == 1)
    assert restored["time_total_s"] > float(last["time_total_s"]) > 0
    played = subprocess.run([sys.executable, "-m", "rllib_pommer.evaluate", "--team", str(moved),
                             "--vs", "static", "--games", "2", "--workers", "1"], cwd=tmp_path,
                            capture_output=True, text=True, timeout=300, env=elsewhere)
    assert played.returncode == 0 and "2 games" in played.stdout, played.stderr[-2000:]
