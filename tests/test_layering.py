"""Data flows one way: the game imports nothing above it, and neither do the scripted agents."""

from __future__ import annotations

import subprocess
import sys

import pytest

HEAVY = ("ray", "torch", "gymnasium")


@pytest.mark.parametrize("modules", [
    ["rllib_pommer.game.engine", "rllib_pommer.game.records", "rllib_pommer.game.verify",
     "rllib_pommer.game.invariants"],
    ["rllib_pommer.agents.registry", "rllib_pommer.agents.action_filter"],
])
def test_lower_layers_do_not_import_ray_torch_or_gymnasium(modules):
    code = (f"import sys, {', '.join(modules)}; "
            f"print(','.join(m for m in {HEAVY!r} if m in sys.modules))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True).stdout.strip()
    assert loaded == ""
