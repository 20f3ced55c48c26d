"""A ladder: one Elo-like rating per named policy, from round-robin arena matches.

Pairs. Every unordered pair of the ladder's policies plays one match: the two names in sorted
order as team A and team B (so a ladder does not depend on the order its policies are listed in),
`games` games with seats balanced (the arena's default) and the ladder's seed. A name may carry
the registry's filter suffixes (`ppo_team_jitter_action`): a filtered policy is a policy of its
own on the ladder.

Records. Each pair's games are an arena records file, `<folder>/records/<a>__vs__<b>.jsonl.gz` (the
rows `evaluate --records` writes, which name their match), written whole when the pair's match
ends (a temporary file renamed), so an interrupted ladder keeps every pair it finished. A pair
whose file holds games 0..games-1 of the ladder's seed is played and never played again; a file
made with another number of games or seed is refused, naming it: its games would not be this
ladder's, and mixing them would rate pairs on unequal terms. Adding a policy adds only its pairs.

Ratings. A Bradley-Terry model fitted by maximum likelihood over all games at once (choix's
iterative Luce spectral ranking on the matrix of wins): policy i beats policy j with probability
1 / (1 + exp(-(t_i - t_j))). A Team game is two copies of one policy against two copies of
another, so the unit rated is the policy, one rating per name. A tie counts as a draw: half a win
to each side, so a pair's score is (wins + ties / 2) / games. Each pair also gets one virtual tie,
so a policy that wins or loses every game still has a finite rating (with 200 games a pair it
moves a pair's score by at most 0.0025; 200 wins out of 200 read as a score of 0.9975, about
1,040 points). The ratings are t * 400 / ln 10, Elo's scale, centred at mean 0 over the
ladder: 200 points above another policy means an expected score (a win plus half a tie) of
1 / (1 + 10^(-200/400)) = 0.76 against it. The fit does not depend on the order of the games
(openskill's online Weng-Lin updates do, and shrink large differences: docs/commands.md).

Intervals. A 95% percentile bootstrap over games: each of `bootstrap` replicates draws every
pair's games with replacement (as many as the pair played: its wins, losses and ties as one
multinomial draw) and fits again; a policy's interval runs from the 2.5th to the 97.5th
percentile of its replicate ratings. The draws come from a numpy generator seeded by the
ladder's seed, so the same records give the same table. A policy that won or lost every game
has the same games in every replicate: its interval is empty and says only that (the table
says so in words).
"""

from __future__ import annotations

import itertools
import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import choix
import numpy as np

from ..agents.registry import KINDS, policy_names, resolve_policy
from ..game.records import read_jsonl
from .match import MatchSpec
from .records import RECORDS_SUFFIX, GameRecord, game_record, write_records

RECORDS_DIR = "records"
LADDER_FILE = "ladder.json"
FILTERED = "_jitter_action"  # the variant of each learned policy a default ladder also rates
ELO = 400 / math.log(10)  # Elo points per unit of Bradley-Terry strength
VIRTUAL_TIES = 1  # tied games that are not played, added to every pair (module docstring)
BOOTSTRAP = 1000
RESULTS = ("win", "loss", "tie")  # team A's results, in the order of a pair's row

Pair = tuple[str, str]


@dataclass(frozen=True)
class Ladder:
    """Which policies (kept sorted), how many games a pair, the seed of every pair's match and
    of the bootstrap, and how many bootstrap replicates the intervals take."""

    policies: tuple[str, ...]
    games: int
    seed: int = 0
    bootstrap: int = BOOTSTRAP

    def __post_init__(self):
        if self.games <= 0:
            raise ValueError(f"games a pair must be a positive number, got {self.games}")
        if self.bootstrap < 1:
            raise ValueError(f"bootstrap replicates must be at least 1, got {self.bootstrap}")
        if len(set(self.policies)) < 2:
            raise ValueError(f"a ladder needs at least two policies, got {list(self.policies)}")
        repeated = sorted({p for p in self.policies if self.policies.count(p) > 1})
        if repeated:
            raise ValueError(f"policy {repeated[0]!r} is listed twice")
        for name in self.policies:
            if Path(name).name != name or name.endswith(".toml"):
                raise ValueError(f"ladder policies are names in policies/ (each names a records "
                                 f"file), not paths: got {name!r}")
            resolve_policy(name)  # an unknown name fails here, before any game
        # Sorted: the order the policies are listed in changes nothing.
        object.__setattr__(self, "policies", tuple(sorted(self.policies)))

    def pairs(self) -> list[Pair]:
        return list(itertools.combinations(self.policies, 2))

    def match(self, pair: Pair) -> MatchSpec:
        return MatchSpec(pair[0], pair[1], self.games, self.seed)


def default_policies() -> list[str]:
    """Every policy in policies/ that plays in this process (scripted or learned, not remote),
    and each learned one also with both of the paper's filters (`FILTERED`)."""
    kinds = {name: resolve_policy(name).kind for name in policy_names()}
    local = [name for name, kind in kinds.items() if KINDS[kind].fixed is not None]
    return local + [name + FILTERED for name in local if KINDS[kinds[name]].fixed == "net"]


def pair_path(folder: Path, pair: Pair) -> Path:
    return folder / RECORDS_DIR / f"{pair[0]}__vs__{pair[1]}{RECORDS_SUFFIX}"


def _read_pair(ladder: Ladder, path: Path, pair: Pair) -> list[GameRecord]:
    """The pair's records, refused (ValueError naming the file) unless they are exactly this
    ladder's games of this pair."""
    try:
        records = [game_record(row) for row in read_jsonl(path)]
    except (KeyError, TypeError) as exc:
        raise ValueError(f"{path}: not an arena records file ({exc!r})") from None
    named = {(r.team, r.vs, tuple(r.filters)) for r in records}
    if named != {(pair[0], pair[1], ())}:
        raise ValueError(f"{path}: holds {sorted(named)[:2]}, not {pair[0]} vs {pair[1]}")
    unknown = [r for r in records if r.result not in RESULTS]
    if unknown:
        raise ValueError(f"{path}: game {unknown[0].game}: result {unknown[0].result!r} is not "
                         f"one of {list(RESULTS)}")
    seeds = sorted({r.seed for r in records})
    if seeds != [ladder.seed] or sorted(r.game for r in records) != list(range(ladder.games)):
        raise ValueError(
            f"{path}: played with {len(records)} games, seed {', '.join(map(str, seeds))}; this "
            f"ladder asks for {ladder.games} games a pair, seed {ladder.seed}: resume with the "
            f"same --games and --seed, or use another --out (never mixed in one ladder)")
    return sorted(records, key=lambda r: r.game)


def played_pairs(ladder: Ladder, folder: Path) -> dict[Pair, list[GameRecord]]:
    """The ladder's pairs already played in `folder`, every file checked before any game."""
    return {pair: _read_pair(ladder, pair_path(folder, pair), pair)
            for pair in ladder.pairs() if pair_path(folder, pair).is_file()}


def save_pair(folder: Path, pair: Pair, records: Sequence[GameRecord]) -> Path:
    """Write the pair's records whole: a temporary file (same kind, hidden name), renamed once
    written."""
    path = pair_path(folder, pair)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(".writing-" + path.name)
    write_records(temporary, records)
    os.replace(temporary, path)
    return path


@dataclass(frozen=True)
class Standing:
    """A policy's place: its rating and 95% interval (Elo-like points), and its games."""

    policy: str
    rating: float
    low: float
    high: float
    games: int
    win: int
    loss: int
    tie: int


def _results(ladder: Ladder, played: Mapping[Pair, Sequence[GameRecord]]) -> np.ndarray:
    """Team A's wins, losses and ties in each of the ladder's pairs, one row per pair."""
    return np.array([[sum(r.result == result for r in played[pair]) for result in RESULTS]
                     for pair in ladder.pairs()], np.int64)


def _fit(count: int, pairs: Sequence[tuple[int, int]], results: np.ndarray) -> np.ndarray:
    """Centred Elo-scale ratings of the Bradley-Terry fit of `results` (rows: wins, losses,
    ties of the first policy of each pair) with one virtual tie a pair (module docstring)."""
    wins = np.zeros((count, count))
    for (a, b), (win, loss, tie) in zip(pairs, results, strict=True):
        wins[a, b] += win + (tie + VIRTUAL_TIES) / 2
        wins[b, a] += loss + (tie + VIRTUAL_TIES) / 2
    strengths = choix.ilsr_pairwise_dense(wins, max_iter=1000)
    return (strengths - strengths.mean()) * ELO


def rate(ladder: Ladder, played: Mapping[Pair, Sequence[GameRecord]]) -> list[Standing]:
    """The ladder's standings, best first, from the played pairs' records (module docstring:
    the model, the scale and the bootstrap intervals)."""
    missing = [pair for pair in ladder.pairs() if pair not in played]
    if missing:
        raise ValueError(f"pair {missing[0][0]} vs {missing[0][1]} has not been played")
    index = {name: k for k, name in enumerate(ladder.policies)}
    pairs = [(index[a], index[b]) for a, b in ladder.pairs()]
    results = _results(ladder, played)
    ratings = _fit(len(index), pairs, results)
    rng = np.random.default_rng(ladder.seed)
    games = results.sum(axis=1)
    replicates = [_fit(len(index), pairs, np.array([rng.multinomial(n, row / n)
                                                    for n, row in zip(games, results,
                                                                      strict=True)]))
                  for _ in range(ladder.bootstrap)]
    low, high = np.percentile(np.array(replicates), [2.5, 97.5], axis=0)
    standings = []
    for name, k in index.items():
        as_a = results[[p for p, (a, _) in enumerate(pairs) if a == k]].sum(axis=0)
        as_b = results[[p for p, (_, b) in enumerate(pairs) if b == k]].sum(axis=0)
        win, loss, tie = as_a + as_b[[1, 0, 2]]  # team B's wins are team A's losses
        standings.append(Standing(name, float(ratings[k]), float(low[k]), float(high[k]),
                                  int(win + loss + tie), int(win), int(loss), int(tie)))
    return sorted(standings, key=lambda s: -s.rating)


def write_ladder(path: Path, ladder: Ladder, standings: Sequence[Standing],
                 played: Mapping[Pair, Sequence[GameRecord]]) -> None:
    """The standings and each pair's results as JSON (a temporary file, renamed)."""
    pairs = [{"team": a, "vs": b, "games": int(row.sum()),
              **{result: int(count) for result, count in zip(RESULTS, row, strict=True)}}
             for (a, b), row in zip(ladder.pairs(), _results(ladder, played), strict=True)]
    data = {"policies": list(ladder.policies), "games_per_pair": ladder.games,
            "seed": ladder.seed, "bootstrap": ladder.bootstrap,
            "standings": [asdict(s) for s in standings], "pairs": pairs}
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text(json.dumps(data, indent=1) + "\n")
    os.replace(temporary, path)


def read_ladder(path: Path) -> tuple[dict, list[Standing]]:
    """A ladder file's settings (games_per_pair, seed, bootstrap, policies) and standings."""
    try:
        data = json.loads(path.read_text())
        standings = [Standing(**row) for row in data.pop("standings")]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{path}: not a ladder file ({exc})") from None
    return data, standings
