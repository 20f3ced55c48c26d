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
     "rllib_pommer.game.invariants", "rllib_pommer.game.raw_codec"],
    ["rllib_pommer.agents.registry", "rllib_pommer.agents.action_filter",
     "rllib_pommer.agents.scripted"],
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


def test_curricula_are_checked_without_ray_or_torch(tmp_path):
    """The run's names, the seat mapping and the curriculum checker: every shipped curriculum,
    and one naming a learned policy (its kind's torch code is not needed to check the name)."""
    learned = tmp_path / "learned.toml"
    learned.write_text('[[stage]]\nname = "x"\nopponent = "imitation"\nepisodes = 5\n')
    check = ("from rllib_pommer.rl.curriculum import curriculum_names, load_curriculum\n"
             "from rllib_pommer.rl.mapping import SeatMapping\n"
             f"loaded = [load_curriculum(n) for n in curriculum_names() + [{str(learned)!r}]]\n"
             "assert loaded[-1].stages[0].opponent == 'imitation' and len(loaded) > 3\n"
             "SeatMapping(0, 'suicide', 'simple')")
    modules = ["rllib_pommer.rl.names", "rllib_pommer.rl.curriculum", "rllib_pommer.rl.mapping"]
    assert _loaded(modules, ("ray", "torch", "gymnasium"), check) == ""
