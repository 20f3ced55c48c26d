"""Data flows one way: game -> agents -> data/features/network -> rl -> jobs. A module may not
import the heavy packages a layer above it brings in."""

from __future__ import annotations

import subprocess
import sys

import pytest


def _loaded(modules: list[str], heavy: tuple[str, ...]) -> str:
    code = (f"import sys, {', '.join(modules)}; "
            f"print(','.join(m for m in {heavy!r} if m in sys.modules))")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip()


@pytest.mark.parametrize("modules", [
    ["rllib_pommer.game.engine", "rllib_pommer.game.records", "rllib_pommer.game.verify",
     "rllib_pommer.game.invariants"],
    ["rllib_pommer.agents.registry", "rllib_pommer.agents.action_filter"],
    ["rllib_pommer.data.collector", "rllib_pommer.data.dagger", "rllib_pommer.data.dataset"],
])
def test_lower_layers_do_not_import_ray_torch_or_gymnasium(modules):
    assert _loaded(modules, ("ray", "torch", "gymnasium")) == ""


def test_imitation_code_does_not_import_ray():
    modules = ["rllib_pommer.bc", "rllib_pommer.learned", "rllib_pommer.learn_speed",
               "rllib_pommer.imitate", "rllib_pommer.collect"]
    assert _loaded(modules, ("ray",)) == ""
