"""The envs in TeamRadio (`game = "radio"`): PettingZoo's API, seed and render tests and
Gymnasium's checker pass, words sent reach the teammate's next observation, and bad words are
refused naming the agent."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test, parallel_seed_test, render_test
from pettingzoo.utils.conversions import parallel_to_aec

from rllib_pommer.envs import RADIO_ENV_ID, PommeTeamEnv, parallel_env
from rllib_pommer.envs.team import MESSAGE_SPACE, RADIO_ACTION_SPACE, MultiAgentTeam
from rllib_pommer.imitation.features import featurize


def test_pettingzoo_api_and_seed_in_radio():
    parallel_api_test(parallel_env(max_steps=200, game="radio"), num_cycles=300)
    parallel_seed_test(lambda: parallel_env(max_steps=200, game="radio"), num_cycles=300)


def test_pettingzoo_render_in_radio():
    def aec_env(render_mode=None):
        return parallel_to_aec(parallel_env(render_mode=None if render_mode == "human"
                                            else render_mode, max_steps=200, game="radio"))
    render_test(aec_env)


@pytest.mark.parametrize("render_mode", [None, "rgb_array"])
def test_gymnasium_check_env_in_radio(render_mode):
    env = gym.make(RADIO_ENV_ID, render_mode=render_mode)
    assert env.action_space == RADIO_ACTION_SPACE
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)


def _words(obs) -> list[int]:
    one_hot = obs["message"]
    assert np.array_equal(one_hot.sum(-1), [1, 1])  # one word in each row
    return one_hot.argmax(-1).tolist()


def test_words_reach_the_teammate_in_the_next_observation():
    env = parallel_env(game="radio", seed=0)
    obs, _ = env.reset(seed=0)
    assert env.observation_space("player_0")["message"] == MESSAGE_SPACE
    assert all(_words(o) == [0, 0] for o in obs.values())  # silence before the first step
    planes = featurize(env.env.last_observation)
    assert all(np.array_equal(obs[f"player_{a}"]["planes"], planes[a]) for a in range(4))
    sent = {"player_0": [0, 3, 5], "player_1": 0, "player_2": np.array([0, 7, 1]),
            "player_3": (0, 0, 2)}
    obs, *_ = env.step(sent)
    # 0 and 2 are a team, 1 and 3 the other; a move alone sends (0, 0)
    assert _words(obs["player_2"]) == [3, 5] and _words(obs["player_0"]) == [7, 1]
    assert _words(obs["player_1"]) == [0, 2] and _words(obs["player_3"]) == [0, 0]
    assert env.env.game.dump()["radio_from_agent"] == [[3, 5], [0, 0], [7, 1], [0, 2]]
    assert all(MESSAGE_SPACE.contains(o["message"]) for o in obs.values())
    obs, *_ = env.step(dict.fromkeys(env.agents, 0))  # the next step's silence replaces them
    assert all(_words(o) == [0, 0] for o in obs.values())


def test_the_gymnasium_seat_hears_its_teammate():
    env = PommeTeamEnv(game="radio", teammate="static", opponents="static", seat=1)
    obs, _ = env.reset(seed=2)
    assert set(obs) == {"planes", "message"} and _words(obs) == [0, 0]
    obs, *_ = env.step(np.array([0, 4, 4]))  # scripted teammates are silent
    assert _words(obs) == [0, 0]
    assert env.team.game.dump()["radio_from_agent"][1] == [4, 4]
    talking = PommeTeamEnv(game="radio", teammate="static_words", opponents="static", seat=1)
    talking.reset(seed=2)
    heard = [_words(talking.step(0)[0]) for _ in range(6)]
    assert len({tuple(w) for w in heard}) > 1  # the teammate's seeded words, step by step
    talking.reset(seed=2)
    assert [_words(talking.step(0)[0]) for _ in range(6)] == heard


def test_the_gymnasium_seats_hear_the_trained_agent_through_radio_act(radio_policy):
    """A radio net across the board hears the trained agent's words of the last step as its
    message input, and answers with its own words, which the trained agent hears."""
    env = PommeTeamEnv(game="radio", teammate=str(radio_policy(greedy=True)),
                       opponents="static", seat=0)
    env.reset(seed=5)
    partner = env.others[2]
    heard = []
    partner.policy.net.hear.register_forward_hook(
        lambda _, inputs, out: heard.append(inputs[0].reshape(2, 8).argmax(-1).tolist()))
    sent = [[3, 5], [7, 1], [0, 6], [2, 2]]
    replies, said = [], []
    for words in sent:
        replies.append(_words(env.step(np.array([0, *words]))[0]))
        said.append(list(partner.words()))
    assert heard == [[0, 0]] + sent[:-1]  # each step it hears the words of the step before
    assert replies == said and any(words != [0, 0] for words in said)


def test_team_env_is_unchanged_beside_radio():
    team, radio = MultiAgentTeam({"seed": 3}), MultiAgentTeam({"seed": 3, "game": "radio"})
    assert team.action_spaces[0] == gym.spaces.Discrete(6) and not team.radio
    assert set(team.observation_spaces[0]) == {"planes", "raw"}
    assert set(radio.observation_spaces[0]) == {"planes", "raw", "message"}
    a, _ = team.reset(seed=3)
    b, _ = radio.reset(seed=3)
    assert all(np.array_equal(a[s]["planes"], b[s]["planes"]) for s in range(4))  # same board
    moves = {0: 1, 1: 2, 2: 3, 3: 4}
    a, ra, *_ = team.step(moves)
    b, rb, *_ = radio.step({s: [m, 1, 2] for s, m in moves.items()})
    assert ra == rb and all(np.array_equal(a[s]["planes"], b[s]["planes"]) for s in range(4))


@pytest.mark.parametrize(("action", "message"), [
    ([1, 8, 0], r"action of agent 'player_0': \[1, 8, 0\] is not in MultiDiscrete"),
    ([6, 0, 0], r"\[6, 0, 0\] is not in MultiDiscrete"),
    ([1, 2], r"\[1, 2\] is not in MultiDiscrete"),
    ([1.0, 2.0, 3.0], r"\[1.0, 2.0, 3.0\] is not in MultiDiscrete"),
    ("1", r"'1' is not in MultiDiscrete"),
])
def test_bad_radio_actions_are_refused(action, message):
    env = parallel_env(game="radio")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        env.step({"player_0": action, **{f"player_{a}": 0 for a in (1, 2, 3)}})


def test_bad_game_is_refused():
    with pytest.raises(ValueError, match=r"game 'ffa' is not one of \['team', 'radio'\]"):
        parallel_env(game="ffa")
    with pytest.raises(ValueError, match="words are sent in TeamRadio games only"):
        MultiAgentTeam().game.step([[1, 2, 3]] * 4)
