"""Matches between two named policies in Team games: one record per game, and their summary.

Every game draws its board and all agents' random streams from `SeedSequence([seed, game index])`,
so a match gives the same records whatever the number of worker processes or their scheduling.
Team A sits on seats {0, 2} in even games and {1, 3} in odd ones (the reference shows a seat
effect: the SimpleAgent mirror wins 50.6% from {0, 2} against 34.6% from {1, 3}), unless seats are
fixed.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass

import numpy as np

from .agents.registry import make_agent
from .game.blast import mark_blast
from .game.constants import TEAM, Action
from .game.engine import Game
from .game.state import (
    A_ALIVE,
    A_AMMO,
    A_COL,
    A_ROW,
    B_BLAST,
    B_COL,
    B_LIFE,
    B_OWNER,
    B_ROW,
    M_BOMBS,
)

SEATS_A = ((0, 2), (1, 3))


@dataclass(frozen=True)
class MatchSpec:
    """Team A (`team`) against team B (`vs`); filters apply to team A's agents only."""

    team: str
    vs: str
    games: int
    seed: int = 0
    filters: tuple[str, ...] = ()
    fixed_seats: bool = False

    def __post_init__(self):
        if self.games <= 0:
            raise ValueError(f"games must be a positive number, got {self.games}")


@dataclass
class GameRecord:
    """What one game did, seen from team A."""

    game: int
    seed: int
    seats_a: list[int]
    result: str  # "win", "loss" or "tie" for team A
    length: int
    died: list[bool]  # by seat
    own_bomb_deaths: list[bool]  # by seat
    bombs_laid: list[int]  # by seat


def seats_of_team_a(spec: MatchSpec, game: int) -> tuple[int, int]:
    return SEATS_A[0] if spec.fixed_seats else SEATS_A[game % 2]


class _Players:
    """The four agents of a worker, built once and reset for every game."""

    def __init__(self, spec: MatchSpec):
        self.spec = spec
        self.by_team = {
            seats: [make_agent(spec.team, spec.filters) if s in seats else make_agent(spec.vs)
                     for s in range(4)]
            for seats in SEATS_A
        }

    def for_game(self, game: int, rngs: Sequence[np.random.Generator]) -> list:
        agents = self.by_team[seats_of_team_a(self.spec, game)]
        for seat, agent in enumerate(agents):
            agent.reset(seat, int(TEAM.game_type), rngs[seat])
        return agents


def _exploded_bombs(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """Rows of `before` that went off this step. An owner lays at most one bomb per step, so
    (owner, life) names a bomb: it survived iff (owner, life - 1) is still listed."""
    survivors = {(int(b[B_OWNER]), int(b[B_LIFE])) for b in after}
    gone = [b[B_LIFE] <= 1 or (int(b[B_OWNER]), int(b[B_LIFE]) - 1) not in survivors
            for b in before]
    return before[np.asarray(gone, bool)] if len(before) else before


def _killed_by_own_bomb(seat: int, cell: tuple[int, int], board: np.ndarray,
                        exploded: np.ndarray) -> bool:
    """The reference statistics' rule: one of the seat's bombs exploded this step and its cross
    (on the pre-step board) covers the death cell."""
    for bomb in exploded[exploded[:, B_OWNER] == seat]:
        cross = np.zeros_like(board)
        mark_blast(board, cross, bomb[B_ROW], bomb[B_COL], bomb[B_BLAST])
        if cross[cell]:
            return True
    return False


def play_game(spec: MatchSpec, game: int, players: _Players) -> GameRecord:
    seeds = np.random.SeedSequence([spec.seed, game]).spawn(5)
    agents = players.for_game(game, [np.random.default_rng(s) for s in seeds[1:]])
    engine = Game(TEAM)
    obs = engine.reset(int(seeds[0].generate_state(1)[0]))
    state = engine.state
    bombs_laid = [0] * 4
    own_bomb_deaths = [False] * 4
    done, info, length = False, {}, 0
    while not done:
        alive = state.agents[0, :, A_ALIVE] != 0
        actions = [agents[s].act(obs.select(s)) if alive[s] else 0 for s in range(4)]
        board = state.board[0].copy()
        bombs = state.bombs[0, : state.meta[0, M_BOMBS]].copy()
        for s in range(4):
            cell = (state.agents[0, s, A_ROW], state.agents[0, s, A_COL])
            if (alive[s] and actions[s] == Action.BOMB and state.agents[0, s, A_AMMO] > 0
                    and not ((bombs[:, B_ROW] == cell[0]) & (bombs[:, B_COL] == cell[1])).any()):
                bombs_laid[s] += 1
        obs, _, done, info = engine.step(actions)
        length += 1
        died = alive & (state.agents[0, :, A_ALIVE] == 0)
        if died.any():
            exploded = _exploded_bombs(bombs, state.bombs[0, : state.meta[0, M_BOMBS]])
            for s in np.flatnonzero(died):
                cell = (state.agents[0, s, A_ROW], state.agents[0, s, A_COL])
                own_bomb_deaths[s] = _killed_by_own_bomb(s, cell, board, exploded)
    seats_a = seats_of_team_a(spec, game)
    winners = info.get("winners", [])
    result = "tie" if not winners else ("win" if seats_a[0] in winners else "loss")
    return GameRecord(game, spec.seed, list(seats_a), result, length,
                      [not a for a in (state.agents[0, :, A_ALIVE] != 0)], own_bomb_deaths,
                      bombs_laid)


def _play_chunk(spec: MatchSpec, games: Sequence[int]) -> list[GameRecord]:
    players = _Players(spec)
    return [play_game(spec, g, players) for g in games]


def play_match(spec: MatchSpec, workers: int | None = None,
               progress: Callable[[int], None] | None = None) -> list[GameRecord]:
    """All games of the match, in game order, on `workers` processes (default: all cores)."""
    _Players(spec)  # fail fast on bad names, before any process starts
    workers = workers or os.cpu_count() or 1
    chunk = max(1, min(25, math.ceil(spec.games / (4 * workers))))
    chunks = [range(i, min(i + chunk, spec.games)) for i in range(0, spec.games, chunk)]
    records: list[GameRecord] = []
    if workers == 1:
        for games in chunks:
            records += _play_chunk(spec, games)
            if progress:
                progress(len(games))
    else:
        with ProcessPoolExecutor(workers) as pool:
            futures = [pool.submit(_play_chunk, spec, games) for games in chunks]
            for future in as_completed(futures):
                done = future.result()
                records += done
                if progress:
                    progress(len(done))
    return sorted(records, key=lambda r: r.game)


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95% Wilson score interval of a rate (the reference statistics use it too)."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (centre - half, centre + half)


def summarise(records: Sequence[GameRecord]) -> dict:
    """Team A's rates with 95% CIs, mean length, own-bomb losses and bombs per agent."""
    n = len(records)
    out: dict = {"games": n}
    for outcome in ("win", "loss", "tie"):
        k = sum(r.result == outcome for r in records)
        out[outcome] = k / n
        out[f"{outcome}_ci95"] = list(wilson(k, n))
    lengths = np.array([r.length for r in records], float)
    out["mean_length"] = float(lengths.mean())
    out["mean_length_ci95"] = _mean_ci(lengths)
    a_seats = [(r, s) for r in records for s in r.seats_a]
    b_seats = [(r, s) for r in records for s in range(4) if s not in r.seats_a]
    out["own_bomb_deaths_a"] = sum(r.own_bomb_deaths[s] for r, s in a_seats)
    games_with_own_death = sum(any(r.own_bomb_deaths[s] for s in r.seats_a) for r in records)
    out["games_with_own_bomb_death_a"] = games_with_own_death / n
    out["bombs_per_agent_a"] = float(np.mean([r.bombs_laid[s] for r, s in a_seats]))
    out["bombs_per_agent_b"] = float(np.mean([r.bombs_laid[s] for r, s in b_seats]))
    return out


def _mean_ci(values: np.ndarray) -> list[float]:
    half = 1.96 * values.std(ddof=1) / math.sqrt(len(values)) if len(values) > 1 else math.inf
    return [float(values.mean() - half), float(values.mean() + half)]


def record_rows(records: Sequence[GameRecord]) -> Iterator[dict]:
    for record in records:
        yield asdict(record)
