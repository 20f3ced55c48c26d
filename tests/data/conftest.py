"""A tiny expert dataset shared by the data tests: 6 games in 2 shards, small row groups."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from rllib_pommer.data import schema
from rllib_pommer.data.collector import Collection
from rllib_pommer.data.dataset import open_dataset
from rllib_pommer.game.constants import TEAM_PRESET
from rllib_pommer.game.engine import Game
from rllib_pommer.game.seeding import game_seeds

TINY_GAMES, TINY_SEED, TINY_SHARD_GAMES = 6, 7, 3
TINY_ROW_GROUP_ROWS = 500  # several row groups per shard, so shuffling spans several windows
TINY_LABEL_DRAWS = 8  # soft targets recorded, so every test reads and writes them


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("tiny")
    with pytest.MonkeyPatch.context() as patch:
        patch.setitem(schema.WRITE_OPTIONS, "row_group_size", TINY_ROW_GROUP_ROWS)
        Collection(out, TINY_GAMES, TINY_SEED, TINY_SHARD_GAMES, TINY_LABEL_DRAWS).run(workers=1)
    return out


def read_all(data_dir: Path):
    """Every shard's rows in shard order, as one table without metadata."""
    return pq.read_table(sorted(data_dir.glob(schema.SHARD_GLOB))).replace_schema_metadata(None)


def row_keys(table) -> np.ndarray:
    """(game, step, seat) of every row."""
    return np.stack([table.column(k).to_numpy().astype(np.int64)
                     for k in ("game", "step_count", "agent_id")], 1)


def replay_against_rows(data_dir: Path, seed: int, game: int, agents: list) -> tuple[int, list]:
    """Replay game `game` of `seed` with the single-game API and `agents` (one per seat, each
    reset from its seat's stream as the arena resets it), checking every living agent's
    observation and action against the dataset's row of that (game, step, seat): the decisions
    checked, and the game's rows no decision matched."""
    obs_rows, action_rows, _ = next(open_dataset(data_dir).iter_batches(10**6, shuffle=False))
    row_of = {tuple(k): i for i, k in enumerate(row_keys(read_all(data_dir)))}
    board_seed, rngs = game_seeds(seed, game)
    engine = Game(TEAM_PRESET)
    for seat, agent in enumerate(agents):
        agent.reset(seat, int(TEAM_PRESET.game_type), rngs[seat])
    obs, step, checked = engine.reset(board_seed), 0, 0
    while not engine.done:
        actions = [0] * 4
        for seat in np.flatnonzero(obs.alive[0]):
            actions[seat] = agents[seat].act(obs.select(seat))
            row = row_of.pop((game, step, seat))
            for name, expected in obs.select(seat)._asdict().items():
                assert np.array_equal(getattr(obs_rows, name)[row], expected), (step, seat, name)
            assert action_rows[row] == actions[seat], (step, seat)
            checked += 1
        obs, _, _, _ = engine.step(actions)
        step += 1
    return checked, [k for k in row_of if k[0] == game]
