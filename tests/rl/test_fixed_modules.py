"""Scripted modules carry their rule's memory through RLlib state and play every scripted kind as
the arena's agents do; frozen networks act as their policy files say, as in the arena."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from ray.rllib.core.columns import Columns

from rllib_pommer.agents.scripted import RULES
from rllib_pommer.agents.simple import new_memory, simple_actions
from rllib_pommer.arena.match import MatchSpec, record_games, seats_of_team_a
from rllib_pommer.envs.team import ACTION_SPACE, OBSERVATION_SPACE, agent_observations
from rllib_pommer.game.raw_codec import unpack_raw
from rllib_pommer.game.seeding import game_seeds
from rllib_pommer.imitation.network import PommerNet
from rllib_pommer.rl.env import PommeEnv
from rllib_pommer.rl.fixed_modules import (
    FrozenNetModule,
    ScriptedModule,
    _seed_streams,
    pack_memory,
)


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


def _module_actions(module, raws, states):
    """The module's actions for some seats' raw observations, with RLlib's state round trip."""
    raw = torch.from_numpy(np.stack(raws))
    if not module.is_stateful():
        return module.forward_exploration({Columns.OBS: {"raw": raw}})[Columns.ACTIONS], states
    out = module.forward_exploration({
        Columns.OBS: {"raw": raw[:, None]},
        Columns.STATE_IN: {"memory": torch.from_numpy(np.stack(states))}})
    return out[Columns.ACTIONS], list(out[Columns.STATE_OUT]["memory"])


@pytest.mark.parametrize("kind", list(RULES))
def test_every_scripted_kind_plays_the_arenas_game_in_the_rllib_env(kind):
    """The arena's recorded game of `kind` (team A) against another scripted kind, played again
    in the RLlib env by scripted modules whose rows start from the random streams the arena's
    agents drew from the same match seed: every action of every step, and the outcome, agree."""
    vs = "random" if kind == "simple" else "simple"
    spec = MatchSpec(kind, vs, games=2, seed=11)
    for game, replay in enumerate(record_games(spec, spec.games)):  # A on {0, 2}, then {1, 3}
        board_seed, generators = game_seeds(spec.seed, game)
        seats_a = seats_of_team_a(spec, game)
        policy = [kind if seat in seats_a else vs for seat in range(4)]
        modules = {name: _module(name) for name in set(policy)}
        # What the arena's agent drew in reset: one stream from its seat's generator.
        states = [pack_memory(new_memory(1, generators[seat]))[0] for seat in range(4)]
        env = PommeEnv({"seed": 0})
        env.reset(seed=0)
        env.last_observation = env.game.reset(board_seed)
        obs = agent_observations(env.last_observation)
        for t, step in enumerate(replay["steps"]):
            actions = {}
            for name, module in modules.items():
                seats = [seat for seat in env.agents if policy[seat] == name]  # not the dead
                if seats:
                    chosen, new = _module_actions(module, [obs[s]["raw"] for s in seats],
                                                  [states[s] for s in seats])
                    actions |= dict(zip(seats, np.asarray(chosen).tolist(), strict=True))
                    for seat, state in zip(seats, new, strict=True):
                        states[seat] = np.asarray(state)
            recorded = {seat: step["actions"][seat] for seat in actions}
            assert actions == recorded, f"{kind} vs {vs}, game {game}, step {t}"
            obs, _, terminateds, _, infos = env.step(actions)
        assert terminateds["__all__"]
        assert sorted(next(iter(infos.values()))["winners"]) == sorted(
            replay["final_info"].get("winners", []))


def _frozen(tmp_path, lines: str) -> FrozenNetModule:
    """A frozen module playing a learned policy file over a random network with `lines`."""
    torch.manual_seed(0)
    torch.save(PommerNet().state_dict(), tmp_path / "net.pt")
    path = tmp_path / f"p{len(list(tmp_path.glob('*.toml')))}.toml"
    path.write_text(f'kind = "learned"\nweights = "net.pt"\n{lines}\n')
    return FrozenNetModule(observation_space=OBSERVATION_SPACE, action_space=ACTION_SPACE,
                           model_config={"policy": str(path)})


def test_a_frozen_opponent_samples_at_its_files_temperature(tmp_path):
    """A training run's frozen opponent reads its policy file as the arena does (issue 50,
    case 12): the distribution it samples from is the net's at the file's temperature, and a
    vanishing one plays the most likely move."""
    env = PommeEnv({"seed": 1})
    obs, _ = env.reset(seed=1)
    planes = torch.from_numpy(np.stack([obs[a]["planes"] for a in range(4)]))
    batch = {Columns.OBS: {"planes": planes}}
    plain = _frozen(tmp_path, "greedy = false")
    logits = plain.pi(planes)
    for temperature in (0.5, 1e-300):
        module = _frozen(tmp_path, f"greedy = false\ntemperature = {temperature}")
        drawn = torch.softmax(module.forward_exploration(batch)[Columns.ACTION_DIST_INPUTS], -1)
        expected = (torch.softmax(logits / 0.5, -1) if temperature == 0.5
                    else torch.eye(logits.shape[-1])[logits.argmax(-1)])
        assert torch.allclose(drawn, expected, atol=1e-6)


def test_a_frozen_opponent_refuses_what_the_arena_refuses(tmp_path):
    with pytest.raises(ValueError, match=r"p0.toml: temperature must be a positive number, "
                                         r"got nan"):
        _frozen(tmp_path, "greedy = false\ntemperature = nan")
