"""The reader: clear errors, a split by game, and batches that hold every sample once."""

from __future__ import annotations

import shutil

import numpy as np
import pyarrow.parquet as pq
import pytest

from rllib_pommer.data import dataset as dataset_module
from rllib_pommer.data.dataset import open_dataset
from rllib_pommer.data.schema import VERSION_KEY, Batch, decode
from rllib_pommer.game.observation import Observation, empty_observations

from .conftest import TINY_GAMES, read_all


def _row_bytes(obs: Observation, actions: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Each sample's fields, action and action counts as one sortable byte string."""
    parts = [np.ascontiguousarray(f).reshape(len(actions), -1).view(np.uint8) for f in obs]
    rows = np.ascontiguousarray(np.concatenate([*parts, actions.reshape(-1, 1).view(np.uint8),
                                                counts], 1))
    return rows.view(f"V{rows.shape[1]}").ravel()


def _same_samples(batches, expected: Batch) -> bool:
    got = np.concatenate([_row_bytes(*batch) for batch in batches])
    return np.array_equal(np.sort(got), np.sort(_row_bytes(*expected)))


@pytest.fixture()
def damaged(tiny_dataset, tmp_path):
    """A copy of the tiny dataset, to be damaged by the test."""
    return shutil.copytree(tiny_dataset, tmp_path / "damaged")


def test_open_counts_samples_and_lists_shards(tiny_dataset):
    data = open_dataset(str(tiny_dataset))
    assert data.num_samples == read_all(tiny_dataset).num_rows
    assert [p.name for p in data.shards] == ["shard-000000.parquet", "shard-000001.parquet"]


def test_missing_or_empty_directory(tmp_path):
    with pytest.raises(ValueError, match="nowhere"):
        open_dataset(tmp_path / "nowhere")
    with pytest.raises(ValueError, match=f"no shards.*{tmp_path}"):
        open_dataset(tmp_path)


def test_truncated_or_foreign_shard_is_named(damaged):
    shard = damaged / "shard-000001.parquet"
    shard.write_bytes(shard.read_bytes()[: shard.stat().st_size // 2])
    with pytest.raises(ValueError, match="shard-000001.parquet"):
        open_dataset(damaged)
    shard.write_text("not parquet at all")
    with pytest.raises(ValueError, match="shard-000001.parquet"):
        open_dataset(damaged)


def test_corrupt_page_is_named_when_read(damaged):
    """Damage inside a data page leaves the footer valid: the page checksum catches it."""
    shard = damaged / "shard-000000.parquet"
    maps = pq.ParquetFile(shard).metadata.row_group(0).column(5)
    data = bytearray(shard.read_bytes())
    middle = maps.data_page_offset + maps.total_compressed_size // 2
    data[middle:middle + 8] = bytes(b ^ 0xFF for b in data[middle:middle + 8])
    shard.write_bytes(bytes(data))
    with pytest.raises(ValueError, match="shard-000000.parquet"):
        for _ in open_dataset(damaged).iter_batches(256, shuffle=False):
            pass


def test_other_schema_version_is_named_with_both_versions(damaged):
    shard = damaged / "shard-000001.parquet"
    table = pq.read_table(shard)
    pq.write_table(table.replace_schema_metadata({**table.schema.metadata, VERSION_KEY: b"0"}),
                   shard)
    with pytest.raises(ValueError, match=r"shard-000001.parquet: schema version 0.* reads 1, 2"):
        open_dataset(damaged)


def test_split_puts_each_game_on_one_side(tiny_dataset):
    data = open_dataset(tiny_dataset)
    table = read_all(tiny_dataset)
    games, everything = table.column("game").to_numpy(), decode(table, data.board_size)
    train, val = data.split(val_fraction=0.5, seed=3)
    assert list(val.games()) == [0, 4, 5]  # a hash of (seed, game): the same on every run
    assert sorted([*train.games(), *val.games()]) == list(range(TINY_GAMES))
    for part in (train, val):
        rows = np.isin(games, part.games())
        assert part.num_samples == rows.sum()
        assert _same_samples(part.iter_batches(64), Batch(everything.obs.select(rows),
                                                          everything.action[rows],
                                                          everything.action_counts[rows]))
    assert list(data.split(0.5, seed=4)[1].games()) == [0, 1, 2, 3, 5]
    assert data.split(0.0)[1].num_samples == 0 and data.split(1.0)[0].num_samples == 0
    with pytest.raises(ValueError, match="val_fraction"):
        data.split(1.5)


@pytest.mark.parametrize(("shuffle", "batch_size"), [(True, 97), (True, 5000), (False, 256)])
def test_every_sample_once_per_epoch(tiny_dataset, monkeypatch, shuffle, batch_size):
    monkeypatch.setattr(dataset_module, "SHUFFLE_ROW_GROUPS", 3)  # several windows and carries
    data = open_dataset(tiny_dataset)
    batches = list(data.iter_batches(batch_size, shuffle=shuffle, seed=1))
    assert [len(b.action) for b in batches[:-1]] == [batch_size] * (len(batches) - 1)
    assert sum(len(b.action) for b in batches) == data.num_samples
    assert _same_samples(batches, decode(read_all(tiny_dataset), data.board_size))
    template = empty_observations(1)
    for obs, actions, counts in batches:
        assert actions.dtype == np.int64 and counts.dtype == np.uint8 and counts.shape[1] == 6
        for name, field in obs._asdict().items():
            expected = getattr(template, name)
            assert field.dtype == expected.dtype and field.shape[1:] == expected.shape[2:], name
    dropped = list(data.iter_batches(batch_size, shuffle=shuffle, seed=1, drop_last=True))
    assert sum(len(b.action) for b in dropped) == data.num_samples // batch_size * batch_size


def test_shuffle_order_follows_the_seed(tiny_dataset):
    data = open_dataset(tiny_dataset)

    def order(**kwargs):
        return np.concatenate([_row_bytes(*b) for b in data.iter_batches(128, **kwargs)])

    assert np.array_equal(order(seed=4), order(seed=4))
    assert not np.array_equal(order(seed=4), order(seed=5))
    assert not np.array_equal(order(seed=4), order(shuffle=False))
