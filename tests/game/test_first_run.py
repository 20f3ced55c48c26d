"""A fresh install says once that it is compiling, instead of sitting silent for minutes."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "rllib_pommer"


def _import_game(root: Path) -> str:
    return subprocess.run([sys.executable, "-c", "import rllib_pommer.game"], cwd=root,
                          env={"PYTHONPATH": str(root)}, capture_output=True, text=True,
                          check=True).stderr


def test_an_empty_kernel_cache_is_announced_and_a_filled_one_is_not(tmp_path):
    shutil.copytree(PACKAGE, tmp_path / "rllib_pommer",
                    ignore=shutil.ignore_patterns("__pycache__"))
    assert "numba compiles the game and agent kernels" in _import_game(tmp_path)
    cache = tmp_path / "rllib_pommer" / "game" / "__pycache__"
    cache.mkdir(exist_ok=True)
    (cache / "step.kernel-1.py311.nbi").write_bytes(b"")
    assert _import_game(tmp_path) == ""
