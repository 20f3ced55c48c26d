"""The 19 planes of the paper's Table 1 on hand-built observations, and the network's shapes."""

from __future__ import annotations

import numpy as np
import torch

from rllib_pommer.game.constants import GameType, Item
from rllib_pommer.game.engine import Games
from rllib_pommer.game.observation import empty_observations
from rllib_pommer.imitation.features import NUM_PLANES, featurize
from rllib_pommer.imitation.network import PommerNet


def _observation(agent_id=0, game_type=GameType.TEAM):
    obs = empty_observations(1).select(0, agent_id)
    obs = type(obs)(*(np.array(f) for f in obs))
    obs.board[:] = Item.FOG
    obs.board[0:5, 0:5] = Item.PASSAGE
    obs.board[0, 0] = Item.RIGID
    obs.board[0, 1] = Item.WOOD
    obs.board[0, 2] = Item.BOMB
    obs.board[0, 3] = Item.FLAMES
    obs.board[1, 0] = Item.EXTRA_BOMB
    obs.board[1, 1] = Item.INCR_RANGE
    obs.board[1, 2] = Item.KICK
    obs.board[2, 2] = Item.AGENT0  # self
    obs.board[3, 3] = Item.AGENT2  # teammate of 0
    obs.board[4, 4] = Item.AGENT1  # first enemy
    obs.board[4, 0] = Item.AGENT3  # second enemy
    obs.bomb_blast_strength[0, 2] = 3
    obs.bomb_life[0, 2] = 7
    obs.position[:] = (2, 2)
    obs.ammo[()] = 2
    obs.blast_strength[()] = 4
    obs.can_kick[()] = True
    obs.game_type[()] = game_type
    return obs


def test_one_hot_board_planes():
    planes = featurize(_observation())
    assert planes.shape == (NUM_PLANES, 11, 11) and planes.dtype == np.float32
    expected = {1: (0, 0), 2: (0, 1), 3: (0, 2), 4: (0, 3), 6: (1, 0), 7: (1, 1), 8: (1, 2)}
    for plane, cell in expected.items():
        assert planes[plane][cell] == 1 and planes[plane].sum() == 1
    assert planes[5].sum() == 121 - 25  # fog outside the 5x5 corner
    assert planes[0, 2, 4] == 1 and planes[0, 2, 2] == 0  # agents are not passage
    assert np.all(planes[:9].sum(axis=0)[np.isin(_observation().board, range(10))] == 1)


def test_position_scalar_bomb_and_desirability_planes():
    planes = featurize(_observation())
    for plane, cell in {9: (2, 2), 10: (3, 3), 11: (4, 4), 12: (4, 0)}.items():
        assert planes[plane][cell] == 1 and planes[plane].sum() == 1
    assert np.all(planes[13] == 0.2) and np.all(planes[14] == 0.4) and np.all(planes[15] == 1)
    assert planes[16, 0, 2] == 0.3 and planes[17, 0, 2] == 0.7 and planes[16].sum() == 0.3
    desirability = planes[18] * 8
    expected = {(1, 0): 0, (0, 1): 1, (0, 4): 2, (9, 9): 3, (4, 4): 4, (0, 0): 5, (3, 3): 6,
                (0, 2): 7, (0, 3): 8, (2, 2): 2}
    for cell, value in expected.items():
        assert desirability[cell] == value, cell


def test_agent_identities_follow_the_seat_and_game_type():
    team1 = featurize(_observation(agent_id=1))
    assert team1[10][4, 0] == 1  # agent 3 is agent 1's teammate
    assert team1[11][2, 2] == 1 and team1[12][3, 3] == 1  # enemies 0 and 2
    ffa0 = featurize(_observation(agent_id=0, game_type=GameType.FFA))
    assert ffa0[10].sum() == 0  # no teammate in FFA
    assert ffa0[11][4, 4] == 1 and ffa0[12][3, 3] == 1  # enemies 1 and 2


def test_batched_rows_equal_single_observations_and_the_network_takes_them():
    games = Games(3)
    games.reset([1, 2, 3])
    for _ in range(20):
        games.step(np.random.default_rng(0).integers(0, 5, (3, 4)))
    rows = games.obs.agent_rows()
    batch = featurize(rows)
    assert batch.shape == (12, NUM_PLANES, 11, 11)
    for i in (0, 5, 11):
        assert np.array_equal(batch[i], featurize(rows.select(i)))
    logits = PommerNet(dropout=0.5).eval()(torch.from_numpy(batch))
    assert logits.shape == (12, 6)
    assert PommerNet(1)(torch.from_numpy(batch)).shape == (12, 1)
    assert sum(p.numel() for p in PommerNet().parameters()) < 5e6 / 4  # weights under 5 MB


def test_teamradio_observations_give_the_team_planes():
    """TeamRadio (game type 3) has Team's teammate and enemies, so the same planes."""
    radio = featurize(_observation(game_type=GameType.TEAM_RADIO))
    np.testing.assert_array_equal(radio, featurize(_observation()))
    assert radio[10, 3, 3] == 1 and radio[11, 4, 4] == 1  # teammate, first enemy
