"""A learned radio network as an agent (TeamRadio, docs/rules.md §10): it hears its teammate's
words as the net's message input and speaks the net's two words, greedy or sampled from its own
stream by seed; a Team network stays silent, and a radio net in a Team game hears silence."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from rllib_pommer.agents.registry import make_agent
from rllib_pommer.agents.speaker import SILENCE, radio_act, speaks
from rllib_pommer.game.constants import RADIO_PRESET, TEAM_PRESET, GameType
from rllib_pommer.imitation.features import message_features
from rllib_pommer.imitation.learned import LearnedAgent, RadioAgent

from ..serving.conftest import team_observations

SEAT = 2


def _observations(config, steps: int = 12):
    return team_observations(SEAT, steps, 4, config)


def _agent(path, game_type=GameType.TEAM_RADIO, seed=0):
    agent = make_agent(path)
    agent.reset(SEAT, int(game_type), np.random.default_rng([seed, SEAT]))
    return agent


def _heard_inputs(agent) -> list[torch.Tensor]:
    """What the agent's net receives on its hearing input, call by call."""
    seen: list[torch.Tensor] = []
    agent.policy.net.hear.register_forward_hook(lambda _, inputs, out: seen.append(inputs[0]))
    return seen


def test_what_a_radio_net_hears_is_its_message_input_and_changes_its_decision(radio_policy):
    agent = _agent(radio_policy(greedy=True))
    assert isinstance(agent, RadioAgent) and speaks(agent)
    seen = _heard_inputs(agent)
    obs = _observations(RADIO_PRESET)[5]
    turns = {message: radio_act(agent, obs, message) for message in [(0, 0), (3, 5), (7, 1)]}
    expected = message_features(np.array([[0, 0], [3, 5], [7, 1]])).reshape(3, -1)
    assert torch.equal(torch.cat(seen), torch.from_numpy(expected))
    assert len(set(turns.values())) > 1  # other words heard, another turn
    with torch.no_grad():  # greedy words: each word head's argmax, for what it heard
        logits = agent.policy.logits(obs.select(None), np.array([[3, 5]]))[0, 6:]
    assert turns[(3, 5)][1:] == tuple(logits.reshape(2, 8).argmax(-1).tolist())


def test_sampled_words_are_reproducible_by_seed_and_not_silence(radio_policy):
    path, observations = radio_policy(greedy=False), _observations(RADIO_PRESET, 30)

    def turns(seed):
        agent = _agent(path, seed=seed)
        return [radio_act(agent, obs, (step % 8, 3)) for step, obs in enumerate(observations)]
    first = turns(1)
    assert turns(1) == first
    assert turns(2) != first
    words = [turn[1:] for turn in first]
    assert len(set(words)) > 5 and all(0 <= w <= 7 for pair in words for w in pair)


def test_a_radio_net_in_team_and_a_team_net_in_radio_are_silent(radio_policy):
    observations = _observations(TEAM_PRESET)
    radio_in_team = _agent(radio_policy(greedy=False), GameType.TEAM)
    seen = _heard_inputs(radio_in_team)
    moves = [radio_in_team.act(obs) for obs in observations]
    assert radio_in_team.words() == SILENCE
    assert all(torch.equal(heard, torch.from_numpy(message_features(
        np.zeros((1, 2), np.int64)).reshape(1, -1))) for heard in seen)
    # its moves draw one uniform per step, as a Team net's: the stream of a plain sampling agent
    rng = np.random.default_rng([0, SEAT])
    probs = [radio_in_team.policy.probabilities(obs.select(None))[0] for obs in observations]
    assert moves == [int(min((np.cumsum(p) < rng.random() * p.sum()).sum(), 5)) for p in probs]

    team_in_radio = _agent("imitation")
    assert type(team_in_radio) is LearnedAgent and not speaks(team_in_radio)
    assert radio_act(team_in_radio, _observations(RADIO_PRESET)[3], (4, 4))[1:] == SILENCE


@pytest.mark.parametrize("filters", [("action",), ("jitter", "action")])
def test_a_filtered_radio_net_still_hears_and_speaks(radio_policy, filters):
    path, obs = radio_policy(greedy=True), _observations(RADIO_PRESET)[7]
    plain = _agent(path)
    filtered = make_agent(path, filters)
    filtered.reset(SEAT, int(GameType.TEAM_RADIO), np.random.default_rng([0, SEAT]))
    assert radio_act(filtered, obs, (6, 2))[1:] == radio_act(plain, obs, (6, 2))[1:] != SILENCE
