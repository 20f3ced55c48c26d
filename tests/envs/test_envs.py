"""The user-facing envs (no Ray): PettingZoo's API, seed and render tests, Gymnasium's env checker,
seeded replays, the named policies in the other seats, and bad arguments."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test, parallel_seed_test, render_test
from pettingzoo.utils.conversions import parallel_to_aec

from rllib_pommer.agents.registry import FILTER_SWITCHES, FILTERS, switched_on
from rllib_pommer.envs import ENV_ID, PommeParallelEnv, PommeTeamEnv, parallel_env
from rllib_pommer.envs.team import PLANES_SPACE, MultiAgentTeam
from rllib_pommer.game.state import A_COL, A_ROW
from rllib_pommer.imitation.features import featurize


def test_pettingzoo_api_and_seed():
    parallel_api_test(parallel_env(max_steps=200), num_cycles=300)
    parallel_seed_test(lambda: parallel_env(max_steps=200), num_cycles=300)


def test_pettingzoo_render():
    def aec_env(render_mode=None):
        # render_test builds a "human" env only to read metadata["render_modes"]; we have no
        # window, so that one is built without rendering.
        return parallel_to_aec(parallel_env(render_mode=None if render_mode == "human"
                                            else render_mode, max_steps=200))
    render_test(aec_env)


def test_pettingzoo_observes_the_planes_of_the_game():
    env = parallel_env()
    obs, _ = env.reset(seed=4)
    planes = featurize(env.env.last_observation)
    assert env.observation_space("player_1") == PLANES_SPACE
    assert all(np.array_equal(obs[f"player_{a}"], planes[a]) for a in range(4))


@pytest.mark.parametrize("render_mode", [None, "rgb_array"])
def test_gymnasium_check_env(render_mode):
    env = gym.make(ENV_ID, render_mode=render_mode)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the checker reports most problems as warnings
        check_env(env.unwrapped)


def _episode(env, seed: int, actions: np.random.Generator):
    obs, _ = env.reset(seed=seed)
    trace = [obs]
    done = False
    while not done:
        obs, reward, terminated, truncated, _ = env.step(int(actions.integers(6)))
        trace += [obs, reward]
        done = terminated or truncated
    return trace


def _same(a, b) -> bool:
    return len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def test_gymnasium_seeded_episodes_replay():
    first, again = (_episode(gym.make(ENV_ID, max_steps=120), 11, np.random.default_rng(0))
                    for _ in range(2))
    assert _same(first, again)
    other = _episode(gym.make(ENV_ID, max_steps=120), 12, np.random.default_rng(0))
    assert not np.array_equal(first[0], other[0])  # another board


def _others_moved(env, steps: int = 30) -> bool:
    """Whether any seat but the trained one left its start cell while the trained one stops."""
    def cells():
        return np.delete(env.team.game.state.agents[0][:, [A_ROW, A_COL]], env.seat, axis=0)
    env.reset(seed=3)
    start = cells()
    for _ in range(steps):
        env.step(0)
    return not np.array_equal(cells(), start)


def test_named_policies_take_the_other_seats():
    assert _others_moved(PommeTeamEnv(seat=1))  # SimpleAgent by default
    still = PommeTeamEnv(seat=1, teammate="static", opponents=["static", "static"])
    assert sorted(still.others) == [0, 2, 3]
    assert not _others_moved(still)


def test_gymnasium_render_draws_the_board():
    env = gym.make(ENV_ID, render_mode="rgb_array")
    env.reset(seed=0)
    before = env.render()
    env.step(1)
    after = env.render()
    assert before.dtype == np.uint8 and before.ndim == 3 and before.shape[2] == 3
    assert before.shape == after.shape and not np.array_equal(before, after)


def test_the_episode_filter_switches_are_the_registry_s():
    """The env draws the switches a curriculum stage sets (`action_filter`, `jitter`) and the
    registry turns them into its filters, as the learner's connector does."""
    env = MultiAgentTeam({"action_filter": 1.0, "jitter": 1.0})
    _, infos = env.reset(seed=3)
    assert set(infos[0]["filters"]) == set(FILTER_SWITCHES.values())
    assert switched_on(infos[0]["filters"]) == tuple(FILTERS)
    env.set_stage("shaped", 0.0, 1.0)
    _, infos = env.reset(seed=3)
    assert switched_on(infos[0]["filters"]) == ("jitter",)


@pytest.mark.parametrize(("make", "message"), [
    (lambda: PommeTeamEnv(opponents="nobody"), "unknown policy 'nobody'"),
    (lambda: PommeTeamEnv(opponents=["simple"] * 3), "opponents: one policy or two"),
    (lambda: PommeTeamEnv(seat=4), "seat 4 is not one of 0..3"),
    (lambda: PommeTeamEnv(render_mode="human"), "render_mode 'human' is not one of"),
    (lambda: PommeTeamEnv(observation="pixels"), "observation 'pixels' is not one of"),
    (lambda: PommeParallelEnv({"reward": "dense"}), "reward mode 'dense' is not one of"),
])
def test_bad_arguments_name_what_was_wrong(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_stepping_after_the_agents_episode_is_an_error():
    env = PommeTeamEnv(max_steps=5)
    env.reset(seed=0)
    for _ in range(5):
        env.step(0)
    with pytest.raises(ValueError, match="call reset"):
        env.step(0)


def _gym_step(action):
    env = PommeTeamEnv(teammate="static", opponents="static")
    env.reset(seed=0)
    return env.step(action)


def _pz_step(actions, reset: bool = True):
    env = parallel_env()
    if reset:
        env.reset(seed=0)
    return env.step(actions)


def _pz_step_after_death():
    """player_0 lays a bomb and stays: it dies; an action for it afterwards is refused."""
    env = parallel_env(seed=0)
    env.reset(seed=0)
    env.step({name: 5 if name == "player_0" else 0 for name in env.agents})
    while "player_0" in env.agents:
        env.step(dict.fromkeys(env.agents, 0))
    return env.step(dict.fromkeys(["player_0", *env.agents], 0))


# What the spaces refuse, the envs refuse: one row per case of issue 40 (9 and 10).
@pytest.mark.parametrize(("call", "message"), [
    (lambda: _gym_step(2.7), r"action of agent 0: 2.7 is not in Discrete\(6\)"),
    (lambda: _gym_step(4.99), r"action of agent 0: 4.99 is not in Discrete\(6\)"),
    (lambda: _gym_step("5"), r"action of agent 0: '5' is not in Discrete\(6\)"),
    (lambda: _gym_step(np.array([1])), r"action of agent 0: array\(\[1\]\) is not in"),
    (lambda: _gym_step(None), r"action of agent 0: None is not in Discrete\(6\)"),
    (lambda: _gym_step(6), r"action of agent 0: 6 is not in Discrete\(6\)"),
    (lambda: PommeTeamEnv(max_steps=0), "max_steps must be an integer >= 1, got 0"),
    (lambda: PommeTeamEnv(max_steps=-1), "max_steps must be an integer >= 1, got -1"),
    (lambda: PommeTeamEnv(max_steps=1.5), "max_steps must be an integer >= 1, got 1.5"),
    (lambda: _pz_step({"player_0": 1}),
     r"no action for \['player_1', 'player_2', 'player_3'\] \(every live agent acts\)"),
    (lambda: _pz_step({}), r"no action for \['player_0', 'player_1', 'player_2', 'player_3'\]"),
    (lambda: _pz_step({"player_0": 1}, reset=False), r"no live agents \(call reset\(\) first"),
    (lambda: _pz_step({"player_9": 1}), "agent 'player_9' is unknown; live agents"),
    (lambda: _pz_step({0: 1}), "agent 0 is unknown; live agents"),
    (_pz_step_after_death, "agent 'player_0' is not live"),
    (lambda: _pz_step({f"player_{a}": 4.9 for a in range(4)}),
     r"action of agent 'player_0': 4.9 is not in Discrete\(6\)"),
    (lambda: parallel_env(max_steps=0), "max_steps must be an integer >= 1, got 0"),
    (lambda: parallel_env(maxsteps=5), r"unknown config key\(s\) \['maxsteps'\]; valid"),
])
def test_the_envs_refuse_what_their_spaces_refuse(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_a_refused_action_moves_nothing():
    """The other seats have not acted (nor drawn from their streams) when an action is refused."""
    env, same = PommeTeamEnv(), PommeTeamEnv()
    env.reset(seed=5)
    same.reset(seed=5)
    with pytest.raises(ValueError):
        env.step(2.7)
    trace = [env.step(a)[0] for a in (1, 2, 3)]
    assert _same(trace, [same.step(a)[0] for a in (1, 2, 3)])
    assert env.step(np.int64(2))[0].shape == env.observation_space.shape  # numpy ints are actions


def test_with_memory_every_seat_reads_22_planes_from_a_fresh_memory_each_game():
    env = MultiAgentTeam({"memory": True, "seed": 7})
    assert env.observation_spaces[0]["planes"].shape == (22, 11, 11)
    games = []
    for _ in range(2):
        obs, _ = env.reset(seed=7)
        trace = [np.stack([obs[a]["planes"] for a in range(4)])]
        assert all(np.array_equal(obs[a]["planes"][:19], featurize(env.last_observation)[a])
                   for a in range(4))
        for _ in range(40):
            obs, *_ = env.step({a: 1 + a % 4 for a in env.agents})
            trace.append(np.stack([obs[a]["planes"] for a in obs]))
        games.append(trace)
    # the second game of the same seed remembers nothing of the first
    assert all(np.array_equal(x, y) for x, y in zip(*games, strict=True))
    assert any(t[:, 19:].any() for t in games[0])
    parallel = parallel_env(memory=True)
    assert parallel.observation_space("player_0").shape == (22, 11, 11)
