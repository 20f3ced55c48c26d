"""Scripted modules carry SimpleAgent's memory through RLlib state and act as the kernel does."""

from __future__ import annotations

import numpy as np
import torch
from ray.rllib.core.columns import Columns

from rllib_pommer.agents.simple import new_memory, simple_actions
from rllib_pommer.rl.env import ACTION_SPACE, OBSERVATION_SPACE, PommeEnv, unpack_raw
from rllib_pommer.rl.fixed_modules import ScriptedModule, _seed_streams


def _module(kind):
    return ScriptedModule(observation_space=OBSERVATION_SPACE, action_space=ACTION_SPACE,
                          model_config={"kind": kind, "max_seq_len": 20})


def test_simple_module_matches_kernel_with_state_round_trips():
    """Two seats played by the module, state passed as RLlib passes it (torch, no time rank),
    against the kernel with one persistent memory: identical actions over a whole game."""
    module, env = _module("simple"), PommeEnv({"seed": 3})
    obs, _ = env.reset(seed=3)
    seats = [1, 3]
    raw = np.stack([obs[a]["raw"] for a in seats])
    reference = new_memory(2, np.random.default_rng(0))
    reference.rng[:] = _seed_streams(raw)
    state = torch.from_numpy(np.stack([module.get_initial_state()["memory"]] * 2))
    steps = 0
    while all(a in obs for a in seats):
        raw = np.stack([obs[a]["raw"] for a in seats])
        out = module.forward_exploration({
            Columns.OBS: {"raw": torch.from_numpy(raw)[:, None]},
            Columns.STATE_IN: {"memory": state}})
        expected = simple_actions(unpack_raw(raw), reference)
        assert np.array_equal(out[Columns.ACTIONS], expected)
        state = torch.from_numpy(out[Columns.STATE_OUT]["memory"])
        actions = dict.fromkeys(env.agents, 0) | dict(zip(seats, expected.tolist(), strict=True))
        obs, _, terminateds, _, _ = env.step(actions)
        steps += 1
        if terminateds["__all__"]:
            break
    assert steps > 20


def test_stateless_kinds():
    env = PommeEnv({"seed": 1})
    obs, _ = env.reset(seed=1)
    batch = {Columns.OBS: {"raw": torch.from_numpy(np.stack([obs[0]["raw"], obs[2]["raw"]]))}}
    assert not _module("suicide").is_stateful()
    assert _module("suicide").forward_inference(batch)[Columns.ACTIONS].tolist() == [5, 5]
    assert _module("static").forward_inference(batch)[Columns.ACTIONS].tolist() == [0, 0]
