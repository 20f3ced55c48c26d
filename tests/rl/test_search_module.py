"""The search agent as a fixed RLlib module plays the arena agent's moves, its memory carried
through RLlib's state."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from ray.rllib.core.columns import Columns

from rllib_pommer.agents.belief import RNG
from rllib_pommer.agents.registry import resolve_policy
from rllib_pommer.agents.search import Effort, new_memory, search_actions
from rllib_pommer.envs.team import ACTION_SPACE, OBSERVATION_SPACE
from rllib_pommer.game.raw_codec import unpack_raw
from rllib_pommer.rl.env import PommeEnv
from rllib_pommer.rl.fixed_modules import _seed_streams, fixed_module_spec
from rllib_pommer.rl.search_module import SearchModule


def _module(policy):
    return SearchModule(observation_space=OBSERVATION_SPACE, action_space=ACTION_SPACE,
                        model_config={"policy": policy, "max_seq_len": 20})


def test_search_module_plays_the_agents_moves_with_state_round_trips():
    """Two seats played by the module, state passed as RLlib passes it, against
    `search_actions` with one persistent memory seeded alike: identical moves over a game."""
    assert fixed_module_spec("search_fast").module_class is SearchModule
    module, env = _module("search_fast"), PommeEnv({"seed": 5})
    effort = Effort.from_params(resolve_policy("search_fast").params, "search_fast")
    obs, _ = env.reset(seed=5)
    seats = [1, 3]
    raw = np.stack([obs[a]["raw"] for a in seats])
    reference = new_memory(2, np.random.default_rng(0))
    reference[:, RNG] = _seed_streams(raw).view(np.int64)
    state = torch.from_numpy(np.stack([module.get_initial_state()["memory"]] * 2))
    steps = bombs = 0
    while all(a in obs for a in seats):
        raw = np.stack([obs[a]["raw"] for a in seats])
        out = module.forward_exploration({
            Columns.OBS: {"raw": torch.from_numpy(raw)[:, None]},
            Columns.STATE_IN: {"memory": state}})
        expected = search_actions(unpack_raw(raw), reference, effort)
        assert np.array_equal(out[Columns.ACTIONS], expected)
        state = torch.from_numpy(out[Columns.STATE_OUT]["memory"])
        bombs += int((expected == 5).sum())
        actions = dict.fromkeys(env.agents, 0) | dict(zip(seats, expected.tolist(), strict=True))
        obs, _, terminateds, _, _ = env.step(actions)
        steps += 1
        if terminateds["__all__"] or steps == 60:
            break
    assert steps > 20 and bombs > 0


def test_search_module_refuses_another_kind():
    with pytest.raises(ValueError, match="'simple' is of kind 'simple', not 'search'"):
        _module("simple")
