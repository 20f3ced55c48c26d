"""Collecting an expert dataset as Parquet shards: in parallel, resumable, crash-safe.

Shard k always covers games [k * shard_games, (k + 1) * shard_games) (the last one fewer), so the
dataset is the same whatever the number of workers, their scheduling or the interruptions. A shard
is written to a temporary name in the output directory, fsynced, then renamed to its final name
and the directory fsynced: a file with a final name is complete, and a run killed at any point
loses at most the shards it was writing. A re-run skips the shards that already exist (after
checking that they belong to the same dataset) and deletes stale temporary files, so only one run
may write into a directory at a time.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from ..game.constants import TEAM_PRESET
from ..util.digest import file_sha256
from ..util.parallel import map_unordered
from .dagger import Actor, check_setup, play_dagger_games
from .expert import SearchExpert, parse_effort, play_games, play_search_games
from .schema import (
    SHARD_GLOB,
    Samples,
    ShardMeta,
    encode,
    read_meta,
    shard_index,
    shard_name,
    write_table,
)

SHARD_GAMES = 128  # ~110,000 samples: a worker peaks ~300 MB above its base; ~1.7 MB on disk
SEARCH_SHARD_GAMES = 16  # search games are slow: a shard of minutes, not of hours, per worker
TEMP_GLOB = ".shard-*.tmp"


@dataclass(frozen=True)
class ShardResult:
    """What writing one shard produced."""
    games: int
    samples: int
    bytes: int


# A learned policy's name -> its batched actor and the file its weights were read from.
ActorOf = Callable[[str], tuple[Actor, Path]]


@dataclass(frozen=True)
class Dagger:
    """Who plays a DAgger dataset: the clone (a learned policy name or file), its opponents, and
    how the clone's name becomes its actor, given by the caller (`collect` passes
    `imitation/learned.greedy_actor`): data/ lies below the learned policies. It must be a
    module-level function, as it goes to the worker processes by reference."""

    policy: str
    opponents: tuple[str, ...]
    actor_of: ActorOf


def plan_shards(games: int, seed: int, shard_games: int, label_draws: int = 0,
                dagger: Dagger | None = None, expert: str = "simple") -> ShardPlan:
    """The shards of a dataset: `games` games from `seed`, `shard_games` a shard, played by four
    `expert`s ("simple", or a policy of kind "search") or by DAgger's clone (labelled by
    SimpleAgent); a ValueError says what does not fit together."""
    if games <= 0 or shard_games <= 0:
        raise ValueError(f"games and shard_games must be positive, got {games}, {shard_games}")
    if not 0 <= label_draws < 256:
        raise ValueError(f"label_draws must be in 0..255, got {label_draws}")
    players = {}
    if expert != "simple":
        if dagger is not None:
            raise ValueError(f"expert {expert!r}: DAgger data are labelled by SimpleAgent "
                             "(leave out --expert)")
        searcher = SearchExpert.resolve(expert)
        players = {"agents": "search", "policy": searcher.name, "effort": searcher.effort_text}
    if dagger is not None:
        check_setup(dagger.opponents, label_draws)
        _, weights = dagger.actor_of(dagger.policy)
        players = {"agents": "dagger", "policy": dagger.policy,
                   "policy_sha256": file_sha256(weights), "opponents": ",".join(dagger.opponents)}
    return ShardPlan(games, ShardMeta(seed, 0, 0, shard_games, TEAM_PRESET.board_size,
                                      label_draws=label_draws, **players))


class ShardPlan(Sequence):
    """The shards of a dataset of `games` games, each made when asked for, so planning a huge
    dataset costs nothing: shard k covers games [k * shard_games, (k + 1) * shard_games)."""

    def __init__(self, games: int, template: ShardMeta):
        self.games, self.template = games, template

    def __len__(self) -> int:
        return -(-self.games // self.template.shard_games)

    def __getitem__(self, index: int) -> ShardMeta:
        if not 0 <= index < len(self):
            raise IndexError(index)
        first = index * self.template.shard_games
        return replace(self.template, first_game=first,
                       stop_game=min(first + self.template.shard_games, self.games))


def _play(meta: ShardMeta, actor_of: ActorOf | None) -> Samples:
    games = range(meta.first_game, meta.stop_game)
    if meta.agents == "search":
        return play_search_games(meta.seed, games, parse_effort(meta.effort),
                                 label_draws=meta.label_draws)
    if meta.agents != "dagger":
        return play_games(meta.seed, games, label_draws=meta.label_draws)
    if actor_of is None:
        raise ValueError(f"{meta.policy}: a DAgger shard needs the clone's actor")
    act, weights = actor_of(meta.policy)
    if file_sha256(weights) != meta.policy_sha256:
        raise ValueError(f"{meta.policy}: its weights {weights} changed since this DAgger "
                         "dataset was planned")
    return play_dagger_games(meta.seed, games, act, tuple(meta.opponents.split(",")),
                             meta.label_draws)


def _fsync_dir(directory: Path) -> None:
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_shard(out_dir: Path, index: int, meta: ShardMeta,
                actor_of: ActorOf | None = None) -> ShardResult:
    """Play the shard's games (a DAgger shard's clone acting by `actor_of`) and publish the
    shard atomically under its final name."""
    samples = _play(meta, actor_of)
    table = encode(samples, meta)
    final = out_dir / shard_name(index)
    temp = out_dir / f".{final.stem}.{os.getpid()}.tmp"
    with open(temp, "wb") as f:
        write_table(table, f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(temp, final)
    _fsync_dir(out_dir)
    return ShardResult(meta.stop_game - meta.first_game, table.num_rows, final.stat().st_size)


def _intact(path: Path) -> tuple[pq.ParquetFile, ShardMeta] | None:
    """The shard and what it covers if every page of it reads back (the page checksums the
    collector writes catch damage inside a page), else None."""
    try:
        shard, meta = read_meta(path)
        shard.read()
    except (ValueError, OSError, pa.ArrowException):
        return None
    return shard, meta


def finished_shards(out_dir: Path, plan: ShardPlan) -> dict[int, ShardResult]:
    """The planned shards already in `out_dir`; ValueError if a shard there belongs elsewhere
    (first of all to another expert's data: experts are never mixed). A damaged shard (cut
    short, or a page that fails its checksum) is deleted, to be played again."""
    done = {}
    for path in sorted(out_dir.glob(SHARD_GLOB)):
        intact = _intact(path)
        if intact is None:
            print(f"{path}: damaged, deleted; it will be played again", file=sys.stderr)
            path.unlink()
            continue
        shard, meta = intact
        if meta.expert != plan.template.expert:
            raise ValueError(f"{path}: collected by expert {meta.expert}; this run's expert is "
                             f"{plan.template.expert}: resume with the same expert, or collect "
                             "into a new directory")
        index = shard_index(path.name)
        index = index if index is not None and index < len(plan) else None
        if index is None or meta != plan[index]:
            expected = plan[index] if index is not None else "no such shard"
            raise ValueError(f"{path} holds {meta}; this run expects {expected}: "
                             "collect into a new directory")
        done[index] = ShardResult(meta.stop_game - meta.first_game, shard.metadata.num_rows,
                                  path.stat().st_size)
    return done


def _die_with_parent() -> None:
    """Worker initializer: on Linux, be killed when the collecting process dies (even by
    SIGKILL), instead of finishing an orphaned shard nobody waits for."""
    if sys.platform.startswith("linux"):
        pr_set_pdeathsig = 1
        ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGKILL)


class Collection:
    """One dataset's shards in `out_dir`: which are finished, and writing the missing ones."""

    def __init__(self, out_dir: Path, games: int, seed: int = 0,
                 shard_games: int = SHARD_GAMES, label_draws: int = 0,
                 dagger: Dagger | None = None, expert: str = "simple"):
        self.out_dir = out_dir
        self.actor_of = dagger.actor_of if dagger else None
        self.plan = plan_shards(games, seed, shard_games, label_draws, dagger, expert)
        out_dir.mkdir(parents=True, exist_ok=True)
        self.results = finished_shards(out_dir, self.plan)

    @property
    def missing(self) -> list[int]:
        return list(self._missing())

    def _missing(self) -> Iterator[int]:
        return (i for i in range(len(self.plan)) if i not in self.results)

    def run(self, workers: int | None = None,
            progress: Callable[[ShardResult], None] | None = None) -> dict[int, ShardResult]:
        """Write the missing shards on `workers` processes (default: all cores; with one, in this
        process), calling `progress` as each completes; return every shard's result."""
        for stale in self.out_dir.glob(TEMP_GLOB):
            stale.unlink()
        workers = min(workers or os.cpu_count() or 1, max(1, len(self.plan) - len(self.results)))
        jobs = ((self.out_dir, i, self.plan[i], self.actor_of) for i in self._missing())
        for (_, index, _, _), result in map_unordered(_write, jobs, workers, _die_with_parent):
            self.results[index] = result
            if progress:
                progress(result)
        return self.results


def _write(job: tuple[Path, int, ShardMeta, ActorOf | None]) -> ShardResult:
    return write_shard(*job)
