"""The raw observation codec: every field of the engine's observations survives the int16 vector,
with its dtype, for one agent or a batch."""

from __future__ import annotations

import numpy as np

from rllib_pommer.game.constants import TEAM_PRESET
from rllib_pommer.game.engine import Games
from rllib_pommer.game.raw_codec import RAW_SIZE, pack_raw, unpack_raw


def test_round_trip_of_played_observations():
    games = Games(3, TEAM_PRESET)
    games.reset([1, 2, 3])
    rng = np.random.default_rng(0)
    for _ in range(40):  # bombs, flames and power-ups on the boards
        games.step(rng.choice([0, 1, 2, 3, 4, 5, 5], size=(3, 4)))
    obs = games.obs
    obs.step_count[...] = 32767  # the largest step count a vector holds
    raw = pack_raw(obs)
    assert raw.shape == (3, 4, RAW_SIZE) and raw.dtype == np.int16
    pairs = [(obs, unpack_raw(raw)), (obs.agent_rows(), unpack_raw(raw.reshape(12, RAW_SIZE))),
             (obs.select(2, 1), unpack_raw(pack_raw(obs.select(2, 1))))]
    for original, back in pairs:
        for field, field_back in zip(original, back, strict=True):
            assert np.array_equal(field, field_back) and field_back.dtype == field.dtype
    assert np.any(obs.bomb_life) and np.any(obs.flame_life)
