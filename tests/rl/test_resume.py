"""`python -m rllib_pommer.train --resume` continues a SIGKILLed or stopped run from its data:
a new Tune trial (a leg) starts from the newest whole checkpoint with stage, counters and
iteration, whatever Tune's pickled state says; it cleans up after the killed run, keeps the
checkpoint at the warm-up's end, and a packed run holds no pickle of Tune's."""

from __future__ import annotations

import contextlib
import importlib
import io
import json
import os
import pickle
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch

from rllib_pommer.imitation.learned import load_policy_net
from rllib_pommer.launch import ray_session
from rllib_pommer.launch.packing import TUNE_STATE
from rllib_pommer.runs.checkpoints import (
    checkpoint_complete,
    checkpoint_iteration,
    load_checkpoint_net,
)
from rllib_pommer.runs.history import legs, read_rows

REPO = Path(__file__).resolve().parents[2]
STABLE_HEADING = "## Stable import paths"


def stable_paths() -> set[str]:
    """The class paths of ours a saved run may name, from docs/architecture.md's list."""
    text = (REPO / "docs" / "architecture.md").read_text().split(STABLE_HEADING + "\n", 1)[1]
    return set(re.findall(r"^- `(rllib_pommer\.[\w.]+)`", text.split("\n## ", 1)[0],
                          flags=re.MULTILINE))


class _Recording(pickle.Unpickler):
    """Loads a pickle and notes every global of ours it names."""

    def __init__(self, data: bytes, seen: set[str]):
        super().__init__(io.BytesIO(data))
        self.seen = seen

    def find_class(self, module, name):
        if module.split(".")[0] == "rllib_pommer":
            self.seen.add(f"{module}.{name}")
        return super().find_class(module, name)


def _hex_pickles(value):
    """The pickles Tune's experiment state holds as hex strings, at any depth."""
    if isinstance(value, dict):
        value = list(value.values())
    if isinstance(value, list):
        for item in value:
            yield from _hex_pickles(item)
    elif isinstance(value, str):
        if len(value) > 16 and re.fullmatch(r"(?:[0-9a-f]{2})+", value):
            yield bytes.fromhex(value)
        elif value[:1] in "[{":
            with contextlib.suppress(ValueError):
                yield from _hex_pickles(json.loads(value))


def pickled_classes(run: Path, trials: list[Path] | None = None) -> set[str]:
    """Every class of ours named by what Tune and RLlib pickled into the run folder `run`: its
    Tune state, and its `trials`' (default: all) params.pkl and checkpoints'
    class_and_ctor_args.pkl."""
    seen: set[str] = set()
    trials = list(run.glob("PPO_*")) if trials is None else trials
    files = [*run.glob("tuner.pkl"), *(p for t in trials for p in t.glob("params.pkl")),
             *(p for t in trials for p in t.glob("**/class_and_ctor_args.pkl"))]
    for path in files:
        _Recording(path.read_bytes(), seen).load()
    for state in run.glob("experiment_state-*.json"):
        for data in _hex_pickles(json.loads(state.read_text())):
            _Recording(data, seen).load()
    return seen


def test_the_stable_paths_are_importable():
    for path in stable_paths():
        module, _, name = path.rpartition(".")
        assert hasattr(importlib.import_module(module), name), path


def _train(out, pi_weights, *extra):
    weights = ["--pi-weights", str(pi_weights)] if pi_weights else []
    return [sys.executable, "-m", "rllib_pommer.train", "--curriculum", "smoke", "--out",
            str(out), *weights, *extra]


def _results(path):
    """The result rows of a trial folder, or of the one trial of a run folder with results (a
    packed leg keeps none)."""
    (results,) = [path / "result.json"] if (path / "result.json").is_file() else list(
        path.glob("*/result.json"))
    return [json.loads(line) for line in results.read_text().splitlines() if line]


def _newest_leg(out: Path) -> Path:
    return max(out.glob("PPO_*"), key=lambda trial: len(legs(trial)))


def test_resume_after_sigkill(tmp_path, pi_weights):
    """SIGKILL the driver alone (as the OOM killer does): Ray's agents outlive it, and Tune's
    state may be left empty or behind the checkpoints. The next start ends those orphans (and
    nothing else) and continues from the newest checkpoint on disk, in a new leg, reading none
    of Tune's state."""
    out = tmp_path / "run"
    process = subprocess.Popen(_train(out, pi_weights), cwd=REPO, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL, start_new_session=True)
    try:
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
        for state in out.glob("*-state-*.json"):
            state.write_bytes(b"")  # as a kill can leave them: nothing reads them any more
        finished = subprocess.run(_train(out, pi_weights, "--resume"), cwd=REPO,
                                  capture_output=True, text=True, timeout=300)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)  # whatever of the killed run's group is left
    assert finished.returncode == 0, finished.stderr[-2000:]
    assert ray_session.session_processes(session_dir) == []
    if orphans:  # Ray 2.60 leaves its dashboard and runtime-env agents
        assert re.search(r"ended [1-9]\d* Ray processes left by the killed run",
                         finished.stderr)
    assert "resuming from PPO_" in finished.stderr
    leg = _newest_leg(out)
    assert len(legs(leg)) == 2
    results = _results(leg)
    first = results[0]
    # Continues after the newest checkpoint on disk, with the lifetime counters it had there.
    assert first["training_iteration"] == newest + 1
    assert first["curriculum"]["episodes"] > first["env_runners"]["num_episodes"]
    final = results[-1]
    assert final["curriculum"]["episodes"] >= final["curriculum"]["total_episodes"]
    assert final["curriculum"]["stage_name"] == "static"
    # What Tune and RLlib pickled for the resumed leg names no class of ours off the map's list.
    named = pickled_classes(out)
    assert named and named <= stable_paths(), sorted(named - stable_paths())
    # The warm-up's end was kept apart from the rotating checkpoints, with pi as it started.
    assert (out / "stages" / "2-static").is_dir()  # the final stage is kept too
    warmup_end = load_checkpoint_net(out / "stages" / "1-warmup").state_dict()
    start = load_policy_net(pi_weights).state_dict()
    assert all(torch.equal(warmup_end[key], start[key]) for key in start)


def _iteration(row) -> int:
    return int(float(row["training_iteration"]))


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
    from and with another layout (an env runner): it goes on from its newest checkpoint, same
    lifetime episode count and stage, its history reads as one run, and the arena plays it. The
    newest checkpoint is numbered below an older one, and an iteration was logged after it (as
    stops have left the campaigns): the pack keeps the newest by iteration, and the resumed
    run's history drops the row it ran again. The pack leaves none of Tune's pickles."""
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
    _wait_for(lambda: list(first.glob("*/checkpoint_000002")), process, 240, "3 iterations")
    stop = subprocess.run([sys.executable, "-m", "rllib_pommer.train", "--out", str(first),
                           "--stop"], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert stop.returncode == 0 and "stopped after PPO_" in stop.stdout, stop.stderr[-2000:]
    assert process.wait(timeout=60) == 130  # it stopped as on Ctrl-C, after a checkpoint
    (trial,) = [p for p in first.iterdir() if p.is_dir() and p.name.startswith("PPO_")]
    *_, lower, higher = sorted(trial.glob("checkpoint_*"))
    newest_iteration = checkpoint_iteration(higher)
    last_result = _results(trial)[-1]
    assert last_result["training_iteration"] == newest_iteration
    after_checkpoint = {**last_result, "training_iteration": newest_iteration + 1,
                        "time_total_s": last_result["time_total_s"] + 1.0}
    with open(trial / "result.json", "a") as f:
        f.write(json.dumps(after_checkpoint) + "\n")
    higher.rename(trial / "swap")
    lower.rename(higher)
    (trial / "swap").rename(lower)  # the newest now has the lower number
    packed = subprocess.run([sys.executable, "-m", "rllib_pommer.train", "--out", str(first),
                             "--pack"], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert packed.returncode == 0, packed.stderr[-2000:]
    assert f"kept {trial.name}/{lower.name}" in packed.stdout
    assert [p.name for p in trial.glob("checkpoint_*")] == [lower.name]
    assert {p.name for p in trial.iterdir() if p.is_file()} == {"history.csv", "params.json"}
    assert [p for pattern in TUNE_STATE for p in first.glob(pattern)] == []
    before = [r for r in read_rows(trial) if _iteration(r) <= newest_iteration]
    moved = tmp_path / "clone" / "campaign" / "run"
    shutil.copytree(first, moved)
    shutil.rmtree(tmp_path / "first")  # nothing may point back to the old place
    assert not pi_weights.exists()
    resumed_log = tmp_path / "resumed.log"
    with open(resumed_log, "wb") as log:
        process = subprocess.Popen(_train(moved, None, "--curriculum", str(curriculum),
                                          "--resume", "--num-env-runners", "1"),
                                   cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=log,
                                   start_new_session=True, env=elsewhere)
    _wait_for(lambda: [c for c in moved.glob("*/checkpoint_*")
                       if c.parent.name != trial.name and checkpoint_complete(c)], process, 240,
              "a checkpoint after the resume")
    _interrupt(process)
    leg = _newest_leg(moved)
    assert legs(leg) == [moved / trial.name, leg]
    assert json.loads((leg / "params.json").read_text())["num_env_runners"] == 1
    rows = read_rows(leg)
    iterations = [_iteration(r) for r in rows]
    assert iterations == list(range(1, len(rows) + 1))  # one run, no gap, no restart
    assert _iteration(rows[len(before)]) == newest_iteration + 1  # from the newest
    last, resumed = before[-1], rows[len(before)]
    lifetime = int(float(last["env_runners/num_episodes_lifetime"]))
    assert (resumed["env_runners/num_episodes_lifetime"] - resumed["env_runners/num_episodes"]
            == lifetime > 12)  # past the warm-up's 12 episodes: in the second stage
    assert resumed["curriculum/iteration_stage_name"] == last[
        "curriculum/iteration_stage_name"] == "static"
    assert resumed["time_total_s"] > float(last["time_total_s"]) > 0  # one clock
    played = subprocess.run([sys.executable, "-m", "rllib_pommer.evaluate", "--team", str(moved),
                             "--vs", "static", "--games", "2", "--workers", "1"], cwd=tmp_path,
                            capture_output=True, text=True, timeout=300, env=elsewhere)
    assert played.returncode == 0 and "2 games" in played.stdout, played.stderr[-2000:]


def test_a_campaign_packed_before_runs_resumed_from_data_resumes(tmp_path):
    """A committed campaign packed when runs still resumed through Tune's pickled state (its
    `tuner.pkl` and `params.pkl` name modules that have since moved): `--resume` reads none of
    that and goes on from its checkpoint in a new leg; `--stop` ends it after an iteration, and
    the run's history reads as one."""
    campaign = REPO / "campaign" / "no_curriculum"
    if not (campaign / "tuner.pkl").is_file():
        pytest.skip("the campaign packed before the change is not in this checkout")
    run = tmp_path / "campaign" / "no_curriculum"
    shutil.copytree(campaign, run)
    (old,) = run.glob("PPO_*")
    (checkpoint,) = old.glob("checkpoint_*")
    iteration = checkpoint_iteration(checkpoint)
    before = read_rows(old)
    log = tmp_path / "resumed.log"
    with open(log, "wb") as out:
        process = subprocess.Popen([sys.executable, "-m", "rllib_pommer.train", "--out",
                                    str(run), "--resume"], cwd=tmp_path, stdout=out,
                                   stderr=subprocess.STDOUT, start_new_session=True)
    try:
        _wait_for(lambda: any(p != old and (p / "result.json").is_file()
                              and (p / "result.json").read_text().strip()
                              for p in run.glob("PPO_*")), process, 300,
                  "an iteration after the resume")
        stop = subprocess.run([sys.executable, "-m", "rllib_pommer.train", "--out", str(run),
                               "--stop"], cwd=tmp_path, capture_output=True, text=True,
                              timeout=300)
        assert stop.returncode == 0, stop.stderr[-2000:]
        assert process.wait(timeout=60) == 130, log.read_text()[-3000:]
    finally:
        if process.poll() is None:
            _interrupt(process)
    leg = _newest_leg(run)
    assert legs(leg) == [old, leg]
    rows = read_rows(leg)
    assert [_iteration(r) for r in rows[: len(before)]] == [_iteration(r) for r in before]
    first = rows[len(before)]
    assert _iteration(first) == iteration + 1
    assert (first["env_runners/num_episodes_lifetime"] - first["env_runners/num_episodes"]
            == int(float(before[-1]["env_runners/num_episodes_lifetime"])))
    named = pickled_classes(run, [leg])  # the old leg's checkpoint stays until the next pack
    assert named <= stable_paths(), sorted(named - stable_paths())
