"""The game: typed state arrays and compiled step and observation kernels (numpy, numba only).

The kernels here and in `agents/` are compiled by numba on first use and cached beside their
modules (`__pycache__/*.nbi`, `*.nbc`). On an install whose cache is empty, the first command
spends a few minutes compiling before it shows progress, so it says so once, here.
"""

from __future__ import annotations

import sys
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parents[1]
if not any(_PACKAGE.glob("*/__pycache__/*.nbi")):
    print("rllib-pommer: first run of this install: numba compiles the game and agent kernels "
          "(about 2-4 minutes on 2 cores, once; cached in the package's __pycache__ folders)",
          file=sys.stderr, flush=True)
