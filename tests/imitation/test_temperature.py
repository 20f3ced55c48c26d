"""A learned policy's sampling temperature (`temperature` in its file): the logits are divided by
it before a sampled move, so a cold policy plays its most likely move and a hot one any move."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import torch

from rllib_pommer.agents.registry import Acting, make_agent
from rllib_pommer.game.constants import (
    NUM_ACTIONS,
    RADIO_NUM_WORDS,
    RADIO_VOCAB_SIZE,
    TEAM_PRESET,
    GameType,
)
from rllib_pommer.imitation.learned import LearnedPolicy
from rllib_pommer.imitation.network import PommerNet, RadioNet

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


@pytest.mark.parametrize("temperature", ["0.001", "1e-300", "1e-307", "1e-320"])
def test_a_cold_policy_plays_its_most_likely_move(tmp_path, temperature):
    """As T -> 0 the moves are the greedy ones, also where logits / T overflows float32 and
    float64 (issue 50, case 11: NaN probabilities, Stop every step), and for a subnormal T,
    also where torch flushes denormals (the trainers do), reading such a divisor as 0."""
    observations = team_observations(SEAT, 12, 4, TEAM_PRESET)
    flushing = torch.tensor(5e-324, dtype=torch.float64).mul(1.0).item() == 0.0  # as it was
    # Python parses the file's 1e-320 as 0.0 in a flushing process (an earlier test's trainer)
    torch.set_flush_denormal(False)
    try:
        cold = _agent(_policy(tmp_path, temperature))
        _plays_greedily(cold, observations)
        torch.set_flush_denormal(True)
        _plays_greedily(cold, observations)
    finally:
        torch.set_flush_denormal(flushing)


def _plays_greedily(cold, observations) -> None:
    batch = type(observations[0])(*(np.stack(f) for f in zip(*observations, strict=True)))
    greedy = cold.policy.logits(batch).argmax(-1).numpy()
    assert (greedy != 0).any()  # so that Stop every step (NaN probabilities) is told apart
    probabilities = cold.policy.probabilities(batch)
    assert np.isfinite(probabilities).all() and np.array_equal(probabilities.argmax(-1), greedy)
    assert [cold.act(obs) for obs in observations] == list(greedy)


def test_a_radio_nets_move_and_words_are_tempered_one_by_one():
    """Each categorical of a radio net (the move, each word) keeps its own distribution: at
    0.5 the probabilities of logits / 0.5, and at a vanishing temperature its most likely
    choice, though the parts' logits lie far apart."""
    logits = torch.randn(5, NUM_ACTIONS + RADIO_NUM_WORDS * RADIO_VOCAB_SIZE,
                         generator=torch.Generator().manual_seed(0))
    logits[:, NUM_ACTIONS:] -= 50.0  # words far below every move
    sizes = [NUM_ACTIONS] + [RADIO_VOCAB_SIZE] * RADIO_NUM_WORDS
    for temperature in (0.5, 1e-300, 5e-324):
        policy = LearnedPolicy(RadioNet(), Path("radio.pt"), Acting(False, temperature))
        tempered = policy.temper(logits).split(sizes, dim=-1)
        for part, raw in zip(tempered, logits.split(sizes, dim=-1), strict=True):
            expected = (torch.softmax(raw.double() / 0.5, -1) if temperature == 0.5
                        else torch.eye(raw.shape[-1], dtype=torch.float64)[raw.argmax(-1)])
            assert torch.allclose(torch.softmax(part.double(), -1), expected, atol=1e-6)


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
    ("true", "temperature must be a float, got True"),
    ('"hot"', "temperature must be a float, got 'hot'"),
])
def test_a_temperature_that_is_not_a_positive_number_is_refused(tmp_path, value, message):
    path = _policy(tmp_path, value)
    with pytest.raises(ValueError, match=re.escape(message)) as info:
        make_agent(path)
    assert path in str(info.value)


def test_a_whole_number_temperature_is_that_float(tmp_path):
    """`temperature = 2` is 2.0, as a float key of a curriculum takes a whole number (issue
    50, case 23)."""
    obs = team_observations(SEAT, 12, 4, TEAM_PRESET)[5]
    batch = type(obs)(*(f[None] for f in obs))
    whole, written = _agent(_policy(tmp_path, "2")), _agent(_policy(tmp_path, "2.0"))
    assert whole.policy.temperature == 2.0
    assert np.array_equal(whole.policy.probabilities(batch), written.policy.probabilities(batch))


def test_a_temperature_beside_greedy_is_refused(tmp_path):
    """A greedy policy takes its most likely move at any temperature: the file says two
    things, one of which would be ignored (issue 50, case 13)."""
    path = Path(_policy(tmp_path, "0.5"))
    path.write_text(path.read_text().replace("greedy = false", "greedy = true"))
    with pytest.raises(ValueError, match=re.escape(
            f"policy file {path}: temperature = 0.5 has no effect with greedy = true")):
        make_agent(str(path))
