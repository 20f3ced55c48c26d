"""Data flows one way: game -> agents -> data/features/network -> rl -> jobs. A module may not
import the heavy packages a layer above it brings in."""

from __future__ import annotations

import subprocess
import sys

import pytest


def _loaded(modules: list[str], heavy: tuple[str, ...], then: str = "") -> str:
    """The `heavy` packages loaded after importing `modules` and running `then`, in a fresh
    interpreter."""
    code = (f"import sys, {', '.join(modules)}\n{then}\n"
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


def test_user_envs_do_not_import_ray_or_torch():
    """The PettingZoo and Gymnasium envs, built and stepped with SimpleAgent seats."""
    play = ("import gymnasium; env = gymnasium.make('rllib_pommer/PommeTeam-v0'); "
            "env.reset(seed=0); env.step(0); "
            "pz = rllib_pommer.envs.parallel_env(); pz.reset(seed=0); "
            "pz.step(dict.fromkeys(pz.agents, 0))")
    assert _loaded(["rllib_pommer.envs"], ("ray", "torch"), play) == ""
