"""Data flows one way: game -> agents -> data/imitation/arena -> rl -> jobs. A module may not
import the heavy packages a layer above it brings in; the top level of the package holds the jobs
alone."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import tomllib

PACKAGE = Path(__file__).resolve().parents[1] / "rllib_pommer"


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


def _package_modules(package: str) -> list[str]:
    return [f"rllib_pommer.{package}.{path.stem}"
            for path in sorted((PACKAGE / package).glob("*.py")) if path.stem != "__init__"]


def test_imitation_and_arena_code_do_not_import_ray():
    """Every module of imitation/ and arena/, and the jobs over them."""
    modules = (_package_modules("imitation") + _package_modules("arena")
               + ["rllib_pommer.imitate", "rllib_pommer.collect", "rllib_pommer.evaluate"])
    assert "rllib_pommer.imitation.speed" in modules and "rllib_pommer.arena.match" in modules
    assert _loaded(modules, ("ray",)) == ""


def test_util_is_standard_library_only():
    """util/ may be imported from any layer, so it brings in nothing: no third-party package and
    no module of ours outside util/."""
    modules = _package_modules("util")
    assert len(modules) == 4
    code = (f"import sys\nbefore = set(sys.modules)\nimport {', '.join(modules)}\n"
            "print(','.join(sorted(m for m in set(sys.modules) - before "
            "if m.split('.')[0] not in sys.stdlib_module_names "
            "and m not in ('rllib_pommer', '__mp_main__') "  # multiprocessing's alias of __main__
            "and not m.startswith('rllib_pommer.util'))))")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip() == ""


def test_the_top_level_holds_the_jobs_alone():
    """Library code lives in the packages; each top-level module is a job with its command."""
    scripts = tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())["project"]["scripts"]
    jobs = {target.split(":")[0].removeprefix("rllib_pommer.") for target in scripts.values()}
    top = {path.stem for path in PACKAGE.glob("*.py")} - {"__init__"}
    assert top == jobs


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


def test_nothing_below_rl_imports_rl():
    """Data flows one way: the game, agents, data, imitation, arena and the user envs never
    reach up into rl/, not even its Ray-free modules (the reward modes are the game's)."""
    packages = ("game", "agents", "data", "imitation", "arena", "envs")
    modules = [m for p in packages for m in _package_modules(p)] + ["rllib_pommer.envs"]
    code = (f"import sys, {', '.join(modules)}\n"
            "print(','.join(sorted(m for m in sys.modules if m.startswith('rllib_pommer.rl'))))")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip() == ""
