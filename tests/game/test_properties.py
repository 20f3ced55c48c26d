"""Invariants that hold after every step of any game, over random seeds and action sequences."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rllib_pommer.game.constants import FFA_PRESET, TEAM_PRESET
from rllib_pommer.game.engine import Game
from rllib_pommer.game.invariants import VIOLATIONS, step_violation
from rllib_pommer.game.state import A_AMMO, A_KICK, M_BOMBS, M_ITEMS

# Bomb-heavy action mix, so that explosions, chains and kicks are frequent.
ACTION = st.sampled_from([0, 1, 2, 3, 4, 5, 5, 1, 2, 3, 4])

games = st.fixed_dictionaries({
    "seed": st.integers(0, 2**31 - 1),
    "ffa": st.booleans(),
    "power_start": st.booleans(),
    "actions": st.lists(st.lists(ACTION, min_size=4, max_size=4), min_size=1, max_size=300),
})


def _start(spec) -> Game:
    game = Game(FFA_PRESET if spec["ffa"] else TEAM_PRESET)
    game.reset(spec["seed"])
    if spec["power_start"]:
        game.state.agents[0, :, A_KICK] = 1
        game.state.agents[0, :, A_AMMO] = 3
    return game


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(games)
def test_invariants_hold_after_every_step(spec):
    game = _start(spec)
    s = game.state
    capacity = s.agents[0, :, A_AMMO].astype(np.int64)
    for t, actions in enumerate(spec["actions"]):
        before = (s.board[0].copy(), s.agents[0].copy(), s.bombs[0].copy(),
                  int(s.meta[0, M_BOMBS]), s.items[0].copy(), int(s.meta[0, M_ITEMS]))
        done = game.step(actions)[2]
        code = step_violation(*before, np.asarray(actions), s.board[0], s.agents[0], s.bombs[0],
                              s.flames[0], s.meta[0], capacity)
        assert code == 0, f"step {t}: {VIOLATIONS[code]}"
        if done:
            break


def test_the_invariant_check_catches_a_broken_state():
    game = Game(TEAM_PRESET)
    game.reset(3)
    s = game.state
    before = (s.board[0].copy(), s.agents[0].copy(), s.bombs[0].copy(), 0, s.items[0].copy(), 0)
    game.step([0, 0, 0, 0])
    s.agents[0, 1, :2] = s.agents[0, 0, :2]  # agent 1 teleported onto agent 0
    code = step_violation(*before, np.zeros(4, np.int64), s.board[0], s.agents[0], s.bombs[0],
                          s.flames[0], s.meta[0], np.ones(4, np.int64))
    assert VIOLATIONS[code] == "two living agents share a cell"


@settings(max_examples=20, deadline=None)
@given(games)
def test_same_seed_and_actions_give_the_same_game(spec):
    runs = []
    for _ in range(2):
        game = _start(spec)
        trace = []
        for actions in spec["actions"]:
            obs, rewards, done, info = game.step(actions)
            trace.append((game.dump(), rewards.tolist(), done, info, obs.board.tobytes()))
            if done:
                break
        runs.append(trace)
    assert runs[0] == runs[1]
