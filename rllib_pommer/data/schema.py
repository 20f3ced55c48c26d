"""The on-disk form of expert samples: one Parquet row per (game, step, agent) decision.

A row holds the agent's raw observation (the `Observation` fields, not the 19 expanded planes),
the action it took, the keys that name it, and (schema 2) `action_counts`: how often the expert
(SimpleAgent, or the search agent) chose each of the 6 actions in the shard's `label_draws`
independent draws of its tie-breaks from the same memory (all zero when the shard was collected
without draws). The five 11x11 maps go into one
fixed-size binary column `maps` (board, bomb_blast_strength, bomb_life, bomb_moving_direction,
flame_life, each row-major), `position` (2 bytes), `alive` (4 bytes) and `action_counts` (6
bytes) into small fixed-size binary columns, and the scalars into the narrowest integer types.
Rows are sorted by (game, agent_id, step_count), so consecutive rows are one agent's consecutive
views, which differ in a few cells: zstd then stores a sample in about 15 bytes.

Every shard carries two key/value metadata entries: `rllib_pommer.schema_version` (SCHEMA_VERSION)
and `rllib_pommer.shard`, a JSON object saying what the shard covers and who played it (see
`ShardMeta`). Shards of schema 1 (no `action_counts`) still read, with zero counts.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from ..game.constants import NUM_ACTIONS
from ..game.observation import Observation, empty_observations

SCHEMA_VERSION = 2
READABLE_VERSIONS = ("1", "2")
VERSION_KEY = b"rllib_pommer.schema_version"
SHARD_KEY = b"rllib_pommer.shard"
SHARD_GLOB = "shard-*.parquet"

MAP_FIELDS = ("board", "bomb_blast_strength", "bomb_life", "bomb_moving_direction", "flame_life")
# On-disk types of the other observation fields (every value fits: positions and counts stay far
# below 256, steps below 65536); the reader widens them back to `empty_observations` dtypes.
STORED_DTYPES = {
    "position": np.uint8,
    "ammo": np.uint8,
    "blast_strength": np.uint8,
    "can_kick": np.bool_,
    "alive": np.bool_,
    "agent_id": np.uint8,
    "game_type": np.uint8,
    "step_count": np.uint16,
}
KEY_DTYPES = {"game": np.int32, "board_seed": np.uint32, "action": np.uint8}
COLUMNS_V1 = ("game", "agent_id", "step_count", "action", "board_seed", "maps",
              *(name for name in STORED_DTYPES if name not in ("agent_id", "step_count")))
COLUMNS = (*COLUMNS_V1, "action_counts")

ROW_GROUP_ROWS = 16384  # ~18 games; the reader's unit of shuffling and of reading
WRITE_OPTIONS = {"compression": "zstd", "compression_level": 3, "row_group_size": ROW_GROUP_ROWS,
                 "write_page_checksum": True}


class Samples(NamedTuple):
    """K recorded decisions: observations with leading shape (K,), and their keys."""

    obs: Observation
    action: np.ndarray  # (K,) int64
    game: np.ndarray  # (K,) index of the game in the dataset
    board_seed: np.ndarray  # (K,) the seed the game's board was generated from
    action_counts: np.ndarray  # (K, 6) uint8 the expert's choices over the label draws

    def take(self, index) -> Samples:
        return Samples(self.obs.select(index), self.action[index], self.game[index],
                       self.board_seed[index], self.action_counts[index])

    @staticmethod
    def concatenate(parts: Sequence[Samples]) -> Samples:
        obs = Observation(*(np.concatenate(f) for f in zip(*(p.obs for p in parts), strict=True)))
        keys = (np.concatenate(f) for f in zip(*(p[1:] for p in parts), strict=True))
        return Samples(obs, *keys)


@dataclass(frozen=True)
class ShardMeta:
    """What a shard covers: games [first_game, stop_game) of the dataset played from `seed`, in
    shards of `shard_games` games. (The dataset's total is not recorded: a dataset can grow.)"""

    seed: int
    first_game: int
    stop_game: int
    shard_games: int
    board_size: int
    game_type: str = "team"
    agents: str = "simple"  # "simple", "search" (four search agents) or "dagger"
    label_draws: int = 0  # the expert's draws behind each row's action_counts (0: none)
    # DAgger shards (agents = "dagger"): the clone that played, the sha256 of its weights and
    # its opponents (comma-separated); see data/dagger.py. Search shards (agents = "search"):
    # `policy` is the search policy's name.
    policy: str = ""
    policy_sha256: str = ""
    opponents: str = ""
    # Search shards: the effort they were played at, "depth=D horizon=H recall=R"
    # (data/expert.format_effort). Written only when set, so the metadata of other shards is
    # what it was before search shards existed.
    effort: str = ""

    @property
    def expert(self) -> str:
        """Who played the shard's games: "simple", the search policy and its effort, or DAgger's
        clone and its opponents."""
        if self.agents == "dagger":
            return f"dagger ({self.policy} {self.policy_sha256[:8]} vs {self.opponents})"
        if self.agents == "search":
            return f"{self.policy} (search, {self.effort})"
        return self.agents

    def __str__(self) -> str:
        return (f"{self.expert} {self.game_type} games {self.first_game}..{self.stop_game - 1} "
                f"of seed {self.seed} in shards of {self.shard_games}")


OPTIONAL_META = ("effort",)  # ShardMeta fields left out of the metadata while empty


def meta_json(meta: ShardMeta) -> str:
    """The shard's `rllib_pommer.shard` metadata entry: `meta` as a JSON object, without the
    OPTIONAL_META fields that are empty."""
    fields = {key: value for key, value in asdict(meta).items()
              if key not in OPTIONAL_META or value}
    return json.dumps(fields)


def shard_name(index: int) -> str:
    return f"shard-{index:06d}.parquet"


def shard_index(name: str) -> int | None:
    """The index `shard_name` made `name` from, or None."""
    match = re.fullmatch(r"shard-(\d{6,})\.parquet", name)
    return int(match.group(1)) if match else None


def _narrow(values: np.ndarray, dtype, name: str) -> np.ndarray:
    """`values` as `dtype`, refusing to wrap around silently."""
    if np.dtype(dtype) != np.bool_ and len(values):
        info = np.iinfo(dtype)
        if values.min() < info.min or values.max() > info.max:
            raise ValueError(f"{name}: values {values.min()}..{values.max()} do not fit {dtype}")
    return np.ascontiguousarray(values, dtype)


def _fixed_size(values: np.ndarray) -> pa.FixedSizeBinaryArray:
    """Each row of `values` (one byte per element) as one fixed-size binary value."""
    rows = np.ascontiguousarray(values).reshape(len(values), -1)
    return pa.FixedSizeBinaryArray.from_buffers(pa.binary(rows.shape[1]), len(rows),
                                                [None, pa.py_buffer(rows)])


def _unpack(column: pa.ChunkedArray, shape: tuple[int, ...]) -> np.ndarray:
    """A fixed-size binary column back into a uint8 array of shape (rows, *shape), no copy."""
    array = column.chunk(0) if column.num_chunks == 1 else column.combine_chunks()
    width = int(np.prod(shape))
    raw = np.frombuffer(array.buffers()[1], np.uint8, len(array) * width, array.offset * width)
    return raw.reshape((len(array), *shape))


def encode(samples: Samples, meta: ShardMeta) -> pa.Table:
    """The shard table of `samples`, sorted by (game, agent_id, step_count)."""
    obs = samples.obs
    order = np.lexsort((obs.step_count, obs.agent_id, samples.game))
    columns = {name: _narrow(getattr(samples, name)[order], dtype, name)
               for name, dtype in KEY_DTYPES.items()}
    maps = np.empty((len(order), len(MAP_FIELDS), *obs.board.shape[1:]), np.uint8)
    for i, name in enumerate(MAP_FIELDS):  # gathered map by map: 3x faster than select + stack
        maps[:, i] = getattr(obs, name)[order]
    columns["maps"] = _fixed_size(maps)
    columns["action_counts"] = _fixed_size(samples.action_counts[order].astype(np.uint8))
    for name, dtype in STORED_DTYPES.items():
        values = _narrow(getattr(obs, name)[order], dtype, name)
        columns[name] = _fixed_size(values.view(np.uint8)) if values.ndim > 1 else values
    table = pa.table({name: columns[name] for name in COLUMNS})
    return table.replace_schema_metadata({VERSION_KEY: str(SCHEMA_VERSION),
                                          SHARD_KEY: meta_json(meta)})


def decode_columns(table: pa.Table, board_size: int) -> dict[str, np.ndarray]:
    """The observation fields (stored dtypes, map fields as views of one (rows, 5, S, S) array)
    and `action` of a shard table or a slice of one."""
    template = empty_observations(1, board_size)
    maps = _unpack(table.column("maps"), (len(MAP_FIELDS), board_size, board_size))
    columns = {name: maps[:, i] for i, name in enumerate(MAP_FIELDS)}
    for name in STORED_DTYPES:
        shape = getattr(template, name).shape[2:]
        column = table.column(name)
        columns[name] = _unpack(column, shape) if shape else column.to_numpy()
    columns["action"] = table.column("action").to_numpy()
    columns["action_counts"] = (_unpack(table.column("action_counts"), (NUM_ACTIONS,))
                                if "action_counts" in table.column_names
                                else np.zeros((table.num_rows, NUM_ACTIONS), np.uint8))
    return columns


class Batch(NamedTuple):
    """Decoded rows: observations with leading shape (B,), int64 actions (B,) and uint8 action
    counts (B, 6)."""

    obs: Observation
    action: np.ndarray
    action_counts: np.ndarray


def to_batch(columns: dict[str, np.ndarray], index=slice(None)) -> Batch:
    """Rows `index` of decoded columns, with the observation in the dtypes of
    `empty_observations` (contiguous copies)."""
    template = empty_observations(1, 1)
    obs = Observation(**{name: np.ascontiguousarray(columns[name][index],
                                                    getattr(template, name).dtype)
                         for name in Observation._fields})
    return Batch(obs, columns["action"][index].astype(np.int64),
                 np.ascontiguousarray(columns["action_counts"][index]))


def decode(table: pa.Table, board_size: int) -> Batch:
    return to_batch(decode_columns(table, board_size))


def write_table(table: pa.Table, file) -> None:
    pq.write_table(table, file, **WRITE_OPTIONS)


def read_meta(path: Path) -> tuple[pq.ParquetFile, ShardMeta]:
    """The open shard and what it covers; ValueError naming the file if it is unreadable, of
    another schema version or lacks a column."""
    try:
        shard = pq.ParquetFile(path, page_checksum_verification=True)
    except (OSError, pa.ArrowException) as exc:
        raise ValueError(f"{path}: not a readable Parquet shard ({exc})") from exc
    metadata = shard.metadata.metadata or {}
    version = metadata.get(VERSION_KEY, b"none").decode()
    if version not in READABLE_VERSIONS:
        raise ValueError(f"{path}: schema version {version}, this reader reads "
                         f"{', '.join(READABLE_VERSIONS)}; re-collect it")
    required = COLUMNS_V1 if version == "1" else COLUMNS
    missing = [name for name in required if name not in shard.schema_arrow.names]
    if missing or SHARD_KEY not in metadata:
        raise ValueError(f"{path}: malformed shard (missing {missing or SHARD_KEY.decode()})")
    try:
        return shard, ShardMeta(**json.loads(metadata[SHARD_KEY]))
    except (ValueError, TypeError) as exc:  # not JSON, not an object, or other keys
        raise ValueError(f"{path}: malformed shard metadata {SHARD_KEY.decode()!r} "
                         f"({exc})") from None
