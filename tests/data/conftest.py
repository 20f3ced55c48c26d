"""A tiny expert dataset shared by the data tests: 6 games in 2 shards, small row groups."""

from __future__ import annotations

from pathlib import Path

import pyarrow.parquet as pq
import pytest

from rllib_pommer.data import schema
from rllib_pommer.data.collector import Collection

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
