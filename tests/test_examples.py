"""The scripts in examples/ run as a user would run them (a fresh interpreter, `--smoke`)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _run(script: str, *args: str, timeout: float = 300) -> str:
    done = subprocess.run([sys.executable, str(EXAMPLES / script), *args], capture_output=True,
                          text=True, timeout=timeout, cwd=EXAMPLES)
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout


def test_gym_reinforce_loop_and_gif(tmp_path):
    gif = tmp_path / "last.gif"
    out = _run("gym_reinforce.py", "--smoke", "--opponents", "static", "--gif", str(gif))
    batches = re.findall(r"episodes (\d+): mean return ([+-][\d.]+), wins (\d+)/2", out)
    assert [b[0] for b in batches] == ["2", "4"]
    assert all(-1.0 <= float(b[1]) <= 1.0 for b in batches)
    frames = int(re.search(r"wrote .*: (\d+) frames", out).group(1))
    assert frames >= 2 and gif.stat().st_size > 0


def test_gym_reinforce_bad_argument_exits_2():
    done = subprocess.run([sys.executable, str(EXAMPLES / "gym_reinforce.py"), "--batch", "0"],
                          capture_output=True, text=True)
    assert done.returncode == 2 and "--batch" in done.stderr


def test_ppo_with_our_modules_trains_one_iteration():
    out = _run("ppo_with_our_modules.py", "--smoke", "--num-cpus", "1")
    line = re.search(r"iter 1: episodes (\d+), learner team's mean return ([+-][\d.]+)", out)
    assert line, out
    assert int(line.group(1)) > 0 and -1.0 <= float(line.group(2)) <= 1.0
