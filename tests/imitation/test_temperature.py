"""A learned policy's sampling temperature (`temperature` in its file): the logits are divided by
it before a sampled move, so a cold policy plays its most likely move and a hot one any move."""

from __future__ import annotations

import re

import numpy as np
import pytest
import torch

from rllib_pommer.agents.registry import make_agent
from rllib_pommer.game.constants import NUM_ACTIONS, TEAM_PRESET, GameType
from rllib_pommer.imitation.network import PommerNet

from ..serving.conftest import team_observations

SEAT = 1


def _policy(tmp_path, temperature: str, stop_bias: float = 0.0) -> str:
    """A sampling policy file over a random network, at `temperature` (TOML text); `stop_bias`
    makes Stop its most likely move by that much in the logits."""
    torch.manual_seed(0)
    net = PommerNet()
    with torch.no_grad():
        net.head[-1].bias[0] += stop_bias
    torch.save(net.state_dict(), tmp_path / "net.pt")
    path = tmp_path / f"t{len(list(tmp_path.glob('*.toml')))}.toml"
    path.write_text(f'kind = "learned"\nweights = "net.pt"\ngreedy = false\n'
                    f'temperature = {temperature}\n')
    return str(path)


def _agent(path: str, seed: int = 0):
    agent = make_agent(path)
    agent.reset(SEAT, int(GameType.TEAM), np.random.default_rng([seed, SEAT]))
    return agent


def test_a_cold_policy_plays_its_most_likely_move(tmp_path):
    observations = team_observations(SEAT, 12, 4, TEAM_PRESET)
    cold = _agent(_policy(tmp_path, "0.001"))
    greedy = cold.policy.probabilities(
        type(observations[0])(*(np.stack(f) for f in zip(*observations, strict=True))))
    moves = [cold.act(obs) for obs in observations]
    assert moves == list(greedy.argmax(-1))


def test_a_hot_policy_plays_every_move_about_as_often(tmp_path):
    obs = team_observations(SEAT, 12, 4, TEAM_PRESET)[5]
    warm = _agent(_policy(tmp_path, "1.0", stop_bias=3.0))
    hot = _agent(_policy(tmp_path, "1000.0", stop_bias=3.0))
    counts = np.bincount([hot.act(obs) for _ in range(1200)], minlength=NUM_ACTIONS)
    assert counts.min() > 140 and counts.max() < 260, counts  # 200 each if uniform
    batch = type(obs)(*(f[None] for f in obs))
    assert warm.policy.probabilities(batch)[0][0] > 0.7  # at temperature 1 the net mostly stops
    assert np.ptp(hot.policy.probabilities(batch)[0]) < 0.01  # the distribution it draws from


@pytest.mark.parametrize(("value", "message"), [
    ("0.0", "temperature must be a positive number, got 0.0"),
    ("-1.5", "temperature must be a positive number, got -1.5"),
    ("nan", "temperature must be a positive number, got nan"),
    ("1", "temperature must be a float, got 1"),
])
def test_a_temperature_that_is_not_a_positive_number_is_refused(tmp_path, value, message):
    path = _policy(tmp_path, value)
    with pytest.raises(ValueError, match=re.escape(message)) as info:
        make_agent(path)
    assert path in str(info.value)
