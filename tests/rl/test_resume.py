"""`python -m rllib_pommer.train --resume` continues a SIGKILLed run with stage and counters, and
keeps the checkpoint at the warm-up's end."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import torch

from rllib_pommer.learned import load_policy_net
from rllib_pommer.rl.checkpoint_policy import load_checkpoint_net

REPO = Path(__file__).resolve().parents[2]


def _train(out, pi_weights, *extra):
    return [sys.executable, "-m", "rllib_pommer.train", "--curriculum", "smoke", "--out",
            str(out), "--pi-weights", str(pi_weights), *extra]


def _results(out):
    (result_file,) = out.glob("*/result.json")
    return [json.loads(line) for line in result_file.read_text().splitlines() if line]


def test_resume_after_sigkill(tmp_path, pi_weights):
    out = tmp_path / "run"
    process = subprocess.Popen(_train(out, pi_weights), cwd=REPO, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 240
        while not list(out.glob("*/checkpoint_000000")) and time.monotonic() < deadline:
            assert process.poll() is None, "training ended before it could be killed"
            time.sleep(0.2)
        time.sleep(1.0)  # let Tune write the experiment state that names the checkpoint
        assert process.poll() is None, "training ended before it could be killed"
    finally:
        os.killpg(process.pid, signal.SIGKILL)  # the run and the Ray it started, nothing else
        process.wait()
    # checkpoint_00000k is written after iteration k + 1; Tune's result files of the killed run
    # may never have left its staging area, so the checkpoints are what survived.
    checkpointed = len(list(out.glob("*/checkpoint_*")))
    assert checkpointed >= 1
    finished = subprocess.run(_train(out, pi_weights, "--resume"), cwd=REPO,
                              capture_output=True, text=True, timeout=300)
    assert finished.returncode == 0, finished.stderr[-2000:]
    results = _results(out)
    resumed = [r for r in results if r["iterations_since_restore"] < r["training_iteration"]]
    assert resumed, "no iterations after a restore: the run started from scratch"
    first = resumed[0]
    # Continues after a checkpoint, with the lifetime counters it had there.
    assert 2 <= first["training_iteration"] <= checkpointed + 1
    assert first["curriculum"]["episodes"] > first["env_runners"]["num_episodes"]
    final = resumed[-1]
    assert final["curriculum"]["episodes"] >= final["curriculum"]["total_episodes"]
    assert final["curriculum"]["stage_name"] == "static"
    # The warm-up's end was kept apart from the rotating checkpoints, with pi as it started.
    warmup_end = load_checkpoint_net(out / "stages" / "1-warmup").state_dict()
    start = load_policy_net(pi_weights).state_dict()
    assert all(torch.equal(warmup_end[key], start[key]) for key in start)
