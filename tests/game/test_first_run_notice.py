"""A new install says once why its first command is slow: numba compiles the kernels."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import rllib_pommer

PACKAGE = Path(rllib_pommer.__file__).resolve().parent
NOTICE = "first run of this install: numba compiles"


def stderr_of_importing_the_game(root: Path) -> str:
    done = subprocess.run([sys.executable, "-c", "import rllib_pommer.game"], cwd=root,
                          env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"},
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stderr


def test_the_notice_shows_until_the_kernels_are_cached(tmp_path):
    shutil.copytree(PACKAGE, tmp_path / "rllib_pommer",
                    ignore=shutil.ignore_patterns("__pycache__", "_shipped"))
    assert NOTICE in stderr_of_importing_the_game(tmp_path)
    cache = tmp_path / "rllib_pommer" / "game" / "__pycache__"
    cache.mkdir(exist_ok=True)
    (cache / "step.kernel-1.py311.nbi").write_bytes(b"")  # numba's index of a cached kernel
    assert NOTICE not in stderr_of_importing_the_game(tmp_path)
