"""Matches between two named policies in Team (or TeamRadio) games, played in worker processes:
one `records.GameRecord` per game, and the replays of chosen games.

Every game draws its board and all agents' random streams from (seed, game index) by the rule of
`game/seeding.py`, so a match gives the same records whatever the number of worker processes or
their scheduling.
Team A sits on seats {0, 2} in even games and {1, 3} in odd ones (the reference shows a seat
effect: the SimpleAgent mirror wins 50.6% from {0, 2} against 34.6% from {1, 3}), unless seats are
fixed.
In TeamRadio games (`MatchSpec.variant` "radio") every agent plays its turn through
`agents/speaker.radio_act`: it hears its teammate's last words (`Games.message`) and sends words
with its move, silence (0, 0) unless it speaks (a `_words` agent, a radio network); replays
record a speaker's `[move, word, word]` and a silent or dead agent's plain move, as the
reference's runner does.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np

from ..agents.base import innermost
from ..agents.registry import make_agent, resolve_policy
from ..agents.speaker import as_passed, radio_act
from ..game.constants import RADIO_NUM_WORDS, GameConfig, has_radio, has_teams, preset
from ..game.engine import Games
from ..game.kills import death_cause, killer_seats
from ..game.records import GameRecorder
from ..game.seeding import game_seeds
from ..game.state import A_ALIVE
from ..util.parallel import map_unordered
from .records import GameRecord

SEATS_A = ((0, 2), (1, 3))


@dataclass(frozen=True)
class MatchSpec:
    """Team A (`team`) against team B (`vs`) in games of the preset `variant` ("team" or
    "radio"); filters apply to team A's agents only."""

    team: str
    vs: str
    games: int
    seed: int = 0
    filters: tuple[str, ...] = ()
    fixed_seats: bool = False
    variant: str = "team"

    def __post_init__(self):
        if self.games <= 0:
            raise ValueError(f"games must be a positive number, got {self.games}")
        if not has_teams(self.config.game_type):
            raise ValueError(f"variant {self.variant!r}: the arena plays team games, "
                             f"'team' or 'radio'")

    @property
    def config(self) -> GameConfig:
        return preset(self.variant)


def seats_of_team_a(spec: MatchSpec, game: int) -> tuple[int, int]:
    return SEATS_A[0] if spec.fixed_seats else SEATS_A[game % 2]


CHUNK_GAMES = 16  # games a worker plays in lockstep; fixed, so records never depend on workers


def _build_players(spec: MatchSpec, seats_a: tuple[int, int]) -> list:
    return [make_agent(spec.team, spec.filters) if s in seats_a else make_agent(spec.vs)
            for s in range(4)]


def _loaded(module: str):
    """The module `module` if this process has loaded it, else None. Learned agents come from
    the registry's plugin kinds, whose modules (and torch) load when the first one is built: a
    match without one never loads them."""
    return sys.modules.get(module)


def _prefetch_learned(players: list[list], obs, active: np.ndarray,
                      message: np.ndarray | None) -> None:
    """One forward pass per learned policy for all its active agents in the chunk, hearing
    `message` (N, 4, 2) in TeamRadio."""
    learned = _loaded("rllib_pommer.imitation.learned")
    if learned is None:  # no learned agent was built in this process
        return
    groups: dict = {}
    for g, seats in enumerate(players):
        for s, agent in enumerate(seats):
            core = innermost(agent)
            if active[g, s] and isinstance(core, learned.LearnedAgent):
                groups.setdefault(id(core.policy), (core.policy, [], []))
                groups[id(core.policy)][1].append(core)
                groups[id(core.policy)][2].append((g, s))
    for policy, agents, rows in groups.values():
        index = tuple(np.array(rows).T)
        policy.prefetch(agents, obs.select(*index), None if message is None else message[index])


def _play_chunk(spec: MatchSpec, games: Sequence[int],
                replay_observations: bool | None = None) -> tuple[list, list]:
    """Play `games` in lockstep; return their records, and their replays unless
    `replay_observations` is None (with the per-agent observations if it is True)."""
    n = len(games)
    seeds = [game_seeds(spec.seed, g) for g in games]
    config = spec.config
    radio = has_radio(config.game_type)
    engine = Games(n, config)
    engine.reset([board_seed for board_seed, _ in seeds])
    players = []
    for i, g in enumerate(games):
        agents = _build_players(spec, seats_of_team_a(spec, g))
        for seat, agent in enumerate(agents):
            agent.reset(seat, int(config.game_type), seeds[i][1][seat])
        players.append(agents)
    torch_threads_for_workers()
    recorders = {}
    if replay_observations is not None:
        for i, g in enumerate(games):
            recorders[i] = GameRecorder(engine, i, seeds[i][0],
                                        _agent_mix(spec, g), replay_observations)
            recorders[i].record.update(game=g, match_seed=spec.seed, team=spec.team, vs=spec.vs,
                                       filters=list(spec.filters),
                                       seats_a=list(seats_of_team_a(spec, g)))
            recorders[i].start()
    lengths = np.zeros(n, np.int64)  # steps each game lasted
    state = engine.state
    while not engine.done.all():
        active = engine.alive & ~engine.done[:, None]
        obs, message = engine.obs, engine.message if radio else None
        _prefetch_learned(players, obs, active, message)
        actions = np.zeros((n, 4), np.int64)
        words = np.zeros((n, 4, RADIO_NUM_WORDS), np.int64)
        for g, s in zip(*np.nonzero(active), strict=True):
            if radio:
                actions[g, s], *words[g, s] = radio_act(players[g][s], obs.select(g, s),
                                                        message[g, s])
            else:
                actions[g, s] = players[g][s].act(obs.select(g, s))
        was_done = engine.done.copy()
        engine.step(np.concatenate([actions[..., None], words], axis=-1) if radio else actions)
        lengths += active.any(axis=1)
        for i, recorder in recorders.items():
            if not was_done[i]:
                recorder.step(_as_passed(players[i], active[i], actions[i], words[i]) if radio
                              else actions[i])
    records = []
    for i, g in enumerate(games):
        seats_a = seats_of_team_a(spec, g)
        winners = [s for s in range(4) if engine.rewards[i, s] == 1]
        result = "tie" if not winners else ("win" if seats_a[0] in winners else "loss")
        died = (state.agents[i, :, A_ALIVE] == 0).tolist()
        records.append(GameRecord(
            g, spec.seed, list(seats_a), result, int(lengths[i]), died,
            [dead and death_cause(s, engine.killers[i, s]) == "self"
             for s, dead in enumerate(died)],
            engine.laid[i].tolist(), spec.team, spec.vs, list(spec.filters),
            [killer_seats(mask) for mask in engine.killers[i]], spec.variant))
    return records, [recorders[i].finish() for i in sorted(recorders)]


def _as_passed(players: list, active: np.ndarray, moves: np.ndarray, words: np.ndarray) -> list:
    """One radio game's actions as the reference's runner passes them: a speaker's
    [move, word, word], a silent or dead agent's plain move."""
    return [as_passed(players[s], (int(moves[s]), *map(int, words[s]))) if active[s]
            else int(moves[s]) for s in range(len(players))]


def _agent_mix(spec: MatchSpec, game: int) -> str:
    seats_a = seats_of_team_a(spec, game)
    return " ".join(spec.team if s in seats_a else spec.vs for s in range(4))


def torch_threads_for_workers() -> None:
    """One torch thread per process where the agents built have loaded torch (a learned
    policy's): the workers already fill the cores. A scripted match loads no torch."""
    torch = _loaded("torch")
    if torch is not None:
        torch.set_num_threads(1)


REMOTE_KINDS = ("http",)  # policy kinds played by a remote agent (`agents/http_agent.py`)


def _plays_remote_agents(spec: MatchSpec) -> bool:
    """A remote (HTTP) agent serves one seat of one game at a time, like a competition container.

    One seating holds both policies, so building its four agents also checks every name."""
    _build_players(spec, SEATS_A[0])
    return any(resolve_policy(name).kind in REMOTE_KINDS for name in (spec.team, spec.vs))


def play_match(spec: MatchSpec, workers: int | None = None,
               progress: Callable[[int], None] | None = None) -> list[GameRecord]:
    """All games of the match in game order, on `workers` processes (default: all cores).

    Matches against remote agents are played one game at a time in this process. Seeds are per
    game, so records do not depend on how games are grouped.
    """
    remote = _plays_remote_agents(spec)  # also fails fast on bad names, before any process starts
    chunk_games = 1 if remote else CHUNK_GAMES
    workers = 1 if remote else (workers or os.cpu_count() or 1)
    chunks = (range(i, min(i + chunk_games, spec.games))
              for i in range(0, spec.games, chunk_games))
    workers = min(workers, -(-spec.games // chunk_games))
    records: list[GameRecord] = []
    for _, (done, _) in map_unordered(partial(_play_chunk, spec), chunks, workers):
        records += done
        if progress:
            progress(len(done))
    return sorted(records, key=lambda r: r.game)


def record_games(spec: MatchSpec, count: int, observations: bool = False) -> list[dict]:
    """Replays (reference JSON Lines schema) of the match's first `count` games, played again
    in this process; the same seeds make them the games `play_match` played."""
    replays: list[dict] = []
    chunk_games = 1 if _plays_remote_agents(spec) else CHUNK_GAMES
    for start in range(0, min(count, spec.games), chunk_games):
        games = range(start, min(start + chunk_games, count, spec.games))
        replays += _play_chunk(spec, games, observations)[1]
    return replays
