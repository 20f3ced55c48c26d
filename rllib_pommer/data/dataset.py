"""Reading an expert dataset back for imitation: validated shards, a split by game, and shuffled
batches streamed a few row groups at a time.

The whole dataset never sits in memory: `iter_batches` reads SHUFFLE_ROW_GROUPS row groups
(~16k samples, ~10 MB decoded each) at a time, in an order shuffled over all shards, and shuffles
the samples within that buffer, so a batch mixes about 150 games. `open_dataset` checks every
shard's footer; damage inside a shard's pages is caught, when they are read, by the page checksums
the collector writes."""

from __future__ import annotations

import hashlib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from ..game.constants import NUM_ACTIONS
from .schema import (
    COLUMNS,
    COLUMNS_V1,
    SHARD_GLOB,
    Batch,
    decode,
    decode_columns,
    read_meta,
    to_batch,
)

SHUFFLE_ROW_GROUPS = 8


@dataclass(frozen=True)
class _Shard:
    path: Path
    row_group_rows: tuple[int, ...]


@dataclass(frozen=True)
class _GameSide:
    """One side of a split: the games whose hash puts them in (or out of) the validation part.

    The hash of (seed, game index) decides, so a game's samples all land on one side, and the
    same game lands on the same side in every run and on every machine."""

    val_fraction: float
    seed: int
    val: bool

    def keeps(self, games: np.ndarray) -> np.ndarray:
        unique, inverse = np.unique(games, return_inverse=True)
        in_val = np.array([_unit_hash(self.seed, int(g)) < self.val_fraction for g in unique],
                          bool)
        return in_val[inverse] == self.val


def _unit_hash(seed: int, game: int) -> float:
    """A number in [0, 1) fixed by (seed, game)."""
    digest = hashlib.blake2b(f"{seed}/{game}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little") / 2**64


def _read(path: Path, row_group: int | None = None, columns=COLUMNS) -> pa.Table:
    """One row group (or the whole shard) of `columns`, or a ValueError naming the file. A
    schema-1 shard gets zero `action_counts`, so shards of both schemas concatenate."""
    try:
        shard = pq.ParquetFile(path, page_checksum_verification=True)
        old = "action_counts" not in shard.schema_arrow.names
        wanted = [c for c in columns if c in COLUMNS_V1] if old else columns
        table = (shard.read(wanted) if row_group is None
                 else shard.read_row_group(row_group, wanted))
    except (OSError, pa.ArrowException) as exc:
        raise ValueError(f"{path}: unreadable shard ({exc})") from exc
    if old and "action_counts" in columns:
        zeros = pa.array([bytes(NUM_ACTIONS)] * table.num_rows, pa.binary(NUM_ACTIONS))
        table = table.append_column("action_counts", zeros).select(list(columns))
    return table.replace_schema_metadata(None)


class Dataset:
    """Some shards of one dataset, optionally restricted to one side of a split (or several)."""

    def __init__(self, shards: Sequence[_Shard], board_size: int,
                 sides: tuple[_GameSide, ...] = ()):
        self._shards = tuple(shards)
        self.board_size = board_size
        self._sides = sides

    @property
    def shards(self) -> list[Path]:
        return [shard.path for shard in self._shards]

    @cached_property
    def num_samples(self) -> int:
        if not self._sides:
            return sum(sum(shard.row_group_rows) for shard in self._shards)
        return sum(len(self._kept_games(shard)) for shard in self._shards)

    def games(self) -> np.ndarray:
        """The sorted indices of the games this dataset (or side of a split) holds."""
        return np.unique(np.concatenate([self._kept_games(shard) for shard in self._shards]))

    def _kept_games(self, shard: _Shard) -> np.ndarray:
        """The game index of each sample of `shard` that this dataset keeps."""
        table = _read(shard.path, columns=["game"])
        return table.column("game").to_numpy()[self._keeps(table)]

    def _keeps(self, table: pa.Table) -> np.ndarray:
        games = table.column("game").to_numpy()
        keeps = np.ones(len(games), bool)
        for side in self._sides:
            keeps &= side.keeps(games)
        return keeps

    def split(self, val_fraction: float = 0.05, seed: int = 0) -> tuple[Dataset, Dataset]:
        """(train, val): about `val_fraction` of the games, with all their samples, go to val."""
        if not 0 <= val_fraction <= 1:
            raise ValueError(f"val_fraction must be in [0, 1], got {val_fraction}")
        return tuple(Dataset(self._shards, self.board_size,
                             self._sides + (_GameSide(val_fraction, seed, val),))
                     for val in (False, True))

    def _read_unit(self, shard: _Shard, row_group: int) -> pa.Table:
        table = _read(shard.path, row_group)
        return table.filter(self._keeps(table)) if self._sides else table

    def iter_batches(self, batch_size: int, shuffle: bool = True, seed: int = 0,
                     drop_last: bool = False) -> Iterator[Batch]:
        """Batches of observations (leading shape (B,)), int64 actions (B,) and action counts
        (B, 6): every sample once.

        Without `shuffle`, samples come in shard order, each sorted by (game, agent, step).
        The last batch is smaller unless `drop_last`, which drops it.
        """
        if batch_size <= 0:
            raise ValueError(f"batch_size must be positive, got {batch_size}")
        rng = np.random.default_rng(seed)
        units = [(shard, g) for shard in self._shards for g in range(len(shard.row_group_rows))]
        if shuffle:
            units = [units[i] for i in rng.permutation(len(units))]
        window = SHUFFLE_ROW_GROUPS if shuffle else 1
        leftover: list[pa.Table] = []
        for start in range(0, len(units), window):
            # one chunk: a fast `take`, zero-copy decoding; the pieces are freed at once
            pool = pa.concat_tables(leftover + [self._read_unit(*unit)
                                                for unit in units[start:start + window]])
            pool = pool.combine_chunks()
            order = rng.permutation(pool.num_rows) if shuffle else np.arange(pool.num_rows)
            full = pool.num_rows - pool.num_rows % batch_size
            leftover = [pool.take(order[full:])]
            columns = decode_columns(pool, self.board_size)
            del pool  # the decoded columns hold the only copy of the buffer
            for i in range(0, full, batch_size):
                yield to_batch(columns, order[i:i + batch_size])
        if leftover and leftover[0].num_rows and not drop_last:
            yield decode(leftover[0], self.board_size)


def open_dataset(*data_dirs: str | Path) -> Dataset:
    """The shards of one or more dataset directories as one dataset (e.g. expert games plus
    DAgger rounds), every shard's footer checked (ValueError naming the problem)."""
    if not data_dirs:
        raise ValueError("no dataset directory given")
    paths = []
    for data_dir in map(Path, data_dirs):
        if data_dir.exists() and not data_dir.is_dir():
            raise ValueError(f"dataset directory {data_dir} is a file, not a folder of shards "
                             f"({SHARD_GLOB}, as `python -m rllib_pommer.collect --out` writes)")
        if not data_dir.is_dir():
            raise ValueError(f"dataset directory {data_dir} does not exist")
        found = sorted(data_dir.glob(SHARD_GLOB))
        if not found:
            raise ValueError(f"no shards ({SHARD_GLOB}) in {data_dir}")
        paths += found
    shards, board_sizes = [], set()
    for path in paths:
        shard, meta = read_meta(path)
        metadata = shard.metadata
        shards.append(_Shard(path, tuple(metadata.row_group(g).num_rows
                                         for g in range(metadata.num_row_groups))))
        board_sizes.add(meta.board_size)
    if len(board_sizes) > 1:
        raise ValueError(f"{', '.join(map(str, data_dirs))}: shards of different board sizes "
                         f"{sorted(board_sizes)}")
    return Dataset(shards, board_sizes.pop())
