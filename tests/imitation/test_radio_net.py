"""The radio network: Team weights load into it with the Team net's move logits exactly, it hears
and speaks once trained, and the Team net and its shipped weights are untouched."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from rllib_pommer.agents.registry import policy_names, resolve_policy
from rllib_pommer.game.constants import RADIO_PRESET, TEAM_PRESET, Item
from rllib_pommer.game.engine import Game
from rllib_pommer.imitation.features import NUM_PLANES, featurize, message_features
from rllib_pommer.imitation.learned import load_policy_net
from rllib_pommer.imitation.network import PommerNet, RadioNet, planes_of
from rllib_pommer.imitation.recall import MEMORY_PLANES

SHIPPED = [resolve_policy(name).file("weights") for name in policy_names()
           if resolve_policy(name).kind == "learned"]


def _inputs(rows: int = 32, seed: int = 0):
    generator = torch.Generator().manual_seed(seed)
    planes = (torch.rand(rows, 19, 11, 11, generator=generator) < 0.2).float()
    words = torch.randint(0, 8, (rows, 2), generator=generator)
    return planes, torch.from_numpy(message_features(words.numpy()))


def test_team_net_keys_and_shapes_are_the_shipped_files():
    team = {key: tuple(value.shape) for key, value in PommerNet().state_dict().items()}
    assert list(team) == ["convs.0.weight", "convs.0.bias", "convs.4.weight", "convs.4.bias",
                          "convs.8.weight", "convs.8.bias", "head.1.weight", "head.1.bias",
                          "head.3.weight", "head.3.bias"]
    assert len(SHIPPED) >= 5
    widths = set()
    for path in set(SHIPPED):
        state = torch.load(path, weights_only=True)
        planes = planes_of(state)
        assert planes in (NUM_PLANES, MEMORY_PLANES), path
        shaped = {key: tuple(value.shape)
                  for key, value in PommerNet(planes=planes).state_dict().items()}
        assert {key: tuple(value.shape) for key, value in state.items()} == shaped, path
        PommerNet(planes=planes).load_state_dict(state)  # strict
        widths.add(planes)
    assert NUM_PLANES in widths  # the clone and the paper's recipes read the paper's 19 planes


@pytest.mark.parametrize("policy", ["imitation", "ppo"])
def test_team_weights_give_the_team_move_logits_exactly(policy):
    path = resolve_policy(policy).file("weights")
    team, radio = load_policy_net(path), load_policy_net(path, radio=True)
    assert isinstance(radio, RadioNet) and not isinstance(team, RadioNet)
    planes, message = _inputs()
    with torch.no_grad():
        moves = team(planes)
        out = radio(planes, message)
        silent = radio(planes, torch.zeros_like(message))
    assert out.shape == (32, 6 + 16)
    assert torch.equal(out[:, :6], moves) and torch.equal(silent[:, :6], moves)
    assert torch.equal(out[:, 6:], torch.zeros(32, 16))  # uniform words at the start
    for key, value in team.state_dict().items():  # the Team weights themselves, unchanged
        assert torch.equal(radio.state_dict()[key], value)


def test_radio_net_learns_to_hear_and_speak_from_zero():
    torch.manual_seed(0)
    net = RadioNet()
    net.load_team_state(load_policy_net(resolve_policy("imitation").file("weights")).state_dict())
    net.convs.requires_grad_(False)  # the Team trunk stays; only the new maps learn
    net.head.requires_grad_(False)
    planes, message = _inputs(16)
    # target: say back the first word heard, as the first word
    target = message[:, 0].argmax(-1)
    optimizer = torch.optim.Adam([net.hear.weight, *net.speak.parameters()], lr=0.05)
    for _ in range(30):
        loss = torch.nn.functional.cross_entropy(net(planes, message)[:, 6:14], target)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    with torch.no_grad():
        said = net(planes, message)[:, 6:14].argmax(-1)
    assert (said == target).float().mean() > 0.9
    assert net.hear.weight.abs().sum() > 0 and net.speak.weight.abs().sum() > 0


def test_radio_state_round_trips_and_a_team_net_refuses_it(tmp_path):
    net = RadioNet()
    torch.nn.init.normal_(net.hear.weight)
    torch.nn.init.normal_(net.speak.weight)
    path = tmp_path / "pi.pt"
    torch.save(net.state_dict(), path)
    loaded = load_policy_net(path)  # a radio file loads as a RadioNet
    assert isinstance(loaded, RadioNet) and loaded.speak is not None
    planes, message = _inputs(8)
    with torch.no_grad():
        assert torch.equal(loaded(planes, message), net.eval()(planes, message))
        # it hears: other words, other move logits
        other = torch.roll(message, 1, dims=0)
        assert not torch.equal(loaded(planes, message)[:, :6], loaded(planes, other)[:, :6])
    with pytest.raises(ValueError, match=r"(?s)pi\.pt: weights do not fit PommerNet.*hear\.weight"):
        load_policy_net(path, radio=False)


def test_radio_value_net_hears_and_loads_a_team_value_net(tmp_path):
    team_vf = PommerNet(1)
    path = tmp_path / "vf.pt"
    torch.save(team_vf.state_dict(), path)
    vf = load_policy_net(path, num_outputs=1, radio=True)
    assert vf.speak is None and set(vf.state_dict()) == set(team_vf.state_dict()) | {
        "hear.weight"}
    planes, message = _inputs(4)
    with torch.no_grad():
        assert torch.equal(vf(planes, message), team_vf.eval()(planes))


def test_message_features_and_radio_planes():
    words = np.array([[[0, 7], [3, 3]]])
    one_hot = message_features(words)
    assert one_hot.shape == (1, 2, 2, 8) and one_hot.dtype == np.float32
    assert one_hot.sum() == 4 and one_hot[0, 0, 1, 7] == 1 and one_hot[0, 1, 0, 3] == 1
    # TeamRadio's planes are Team's: same board, same teammate and enemy planes
    team, radio = Game(TEAM_PRESET), Game(RADIO_PRESET)
    a, b = team.reset(5), radio.reset(5)
    assert int(b.game_type[0]) == 3
    for rows in (a, b):  # agent 0 sees its teammate (agent 2) and an enemy (agent 3) nearby
        rows.board[0, 1, 2], rows.board[0, 2, 1] = Item.AGENT2, Item.AGENT3
    assert np.array_equal(featurize(a), featurize(b))
    assert featurize(b)[0, 10, 1, 2] == 1 and featurize(b)[0, 12, 2, 1] == 1
