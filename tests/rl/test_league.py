"""A stage's league of opponents: checked on load, taking turns by whole seat cycles, each
opponent's outcomes logged apart; mappings pickled before leagues still map."""

from __future__ import annotations

from collections import Counter
from types import SimpleNamespace

import pytest

from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.mapping import SeatMapping
from rllib_pommer.curriculum.names import LEARNER
from rllib_pommer.rl.config import build_config

from .conftest import ECHO_ENV

LEAGUE_SMOKE = """
name = "league_smoke"
description = "A league of two opponents, test-sized."
max_steps = 40
[ppo]
train_batch_size = 320
num_epochs = 1
num_envs_per_env_runner = 4
[[stage]]
name = "league"
opponent = ["static", "simple_nobomb"]
episodes = 16
"""


def _seats_and_opponents(mapping: SeatMapping, episodes: int) -> list[tuple[int, str]]:
    played = []
    for n in range(episodes):
        episode = SimpleNamespace(id_=f"e{n}")
        modules = [mapping(agent, episode) for agent in range(4)]
        seat = modules.index(LEARNER)
        enemies = {modules[a] for a in range(4) if a % 2 != seat % 2}
        assert modules[(seat + 2) % 4] == "suicide" and len(enemies) == 1
        played.append((seat, enemies.pop()))
    return played


def test_a_league_takes_turns_so_each_opponent_meets_every_seat_alike():
    played = _seats_and_opponents(SeatMapping(1, "suicide", ("static", "simple", "ppo")), 24)
    assert Counter(played) == {(seat, name): 2 for seat in range(4)
                               for name in ("static", "simple", "ppo")}
    assert [name for _, name in played[:8]] == ["static"] * 4 + ["simple"] * 4
    assert set(_seats_and_opponents(SeatMapping(0, "suicide", "simple"), 8)) == {
        (seat, "simple") for seat in range(4)}


def test_a_league_loads_as_a_tuple_and_its_members_are_checked(tmp_path):
    path = tmp_path / "league.toml"
    path.write_text(LEAGUE_SMOKE)
    curriculum = load_curriculum(path)
    assert curriculum.stages[0].opponent == ("static", "simple_nobomb")
    assert curriculum.policies() == ["suicide", "static", "simple_nobomb"]
    for bad, words in (('[]', "a list of distinct policy names, got []"),
                       ('["static", "static"]', "distinct"),
                       ('["static", 3]', "got ['static', 3]"),
                       ('["static", "simpel"]', "key 'opponent': unknown policy 'simpel'")):
        path.write_text(LEAGUE_SMOKE.replace('["static", "simple_nobomb"]', bad))
        with pytest.raises(ValueError, match=words.replace("[", r"\[").replace("]", r"\]")):
            load_curriculum(path)


def test_a_league_plays_each_opponent_and_logs_each_ones_outcomes(ray_session, pi_weights,
                                                                  tmp_path):
    path = tmp_path / "league.toml"
    path.write_text(LEAGUE_SMOKE)
    algo = build_config(load_curriculum(path), pi_weights=pi_weights, env=ECHO_ENV).build_algo()
    try:
        runners = algo.train()["env_runners"]
    finally:
        algo.stop()
    for name in ("static", "simple_nobomb"):
        rates = [runners[f"learner_{result}_vs_{name}"] for result in ("win", "loss", "tie")]
        assert sum(rates) == pytest.approx(1.0)
