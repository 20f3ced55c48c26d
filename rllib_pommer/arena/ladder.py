"""A ladder: one Elo-like rating per named policy, from round-robin arena matches.

Pairs. Every unordered pair of the ladder's policies plays one match: the two names in sorted
order as team A and team B (so a ladder does not depend on the order its policies are listed in),
`games` games with seats balanced (the arena's default) and the ladder's seed. A name may carry
the registry's filter suffixes (`ppo_team_jitter_action`): a filtered policy is a policy of its
own on the ladder.

Records. Each pair's games are an arena records file, `<folder>/records/<a>__vs__<b>.jsonl` (the
rows `evaluate --records` writes, which name their match), written whole when the pair's match
ends (a temporary file renamed), so an interrupted ladder keeps every pair it finished. A pair
whose file holds games 0..games-1 of the ladder's seed is played and never played again; a file
made with another number of games or seed is refused, naming it: its games would not be this
ladder's, and mixing them would rate pairs on unequal terms. Adding a policy adds only its pairs.

Ratings. openskill's Bradley-Terry full-pairing model (Weng and Lin 2011). A Team game is two
copies of one policy against two copies of another, so the unit rated is the policy: each game
is a one-against-one game between the two policies' ratings (two players sharing one rating
would count every game twice). A win and a loss are ranks 0 and 1; a tie is equal ranks, a
draw, which the model's update scores as half a win. Frozen policies do not change, so the
model's dynamics tau is 0. The update's win probability 1 / (1 + exp(-(mu_a - mu_b) / c)), with
c = sqrt(2 beta^2 + sigma_a^2 + sigma_b^2), is Elo's 1 / (1 + 10^(-d / 400)) when beta =
400 / (ln 10 sqrt 2) and the sigmas are small beside beta, as they are after a few hundred
games: `SCALE` sets beta so, and a rating is on Elo's scale, 200 points above another meaning an
expected score (a win plus half a tie) of 0.76 against it. Ratings are centred at mean 0 over
the ladder's policies. openskill rates online, one game after another; the ladder's games are
fed once, in an order shuffled by the ladder's seed. A policy that wins or loses every game has
no finite Bradley-Terry rating; its rating then stops where openskill's prior (sigma = 2 beta)
and the shrinking updates leave it.

Intervals. A 95% percentile bootstrap over games: each of `bootstrap` replicates draws every
pair's games with replacement (as many as the pair played), rates them again in a freshly
shuffled order and centres them; a policy's interval runs from the 2.5th to the 97.5th
percentile of its replicate ratings. The replicates' draws come from a numpy generator seeded
by the ladder's seed, so the same records give the same table. The interval covers the chance
in the games played and in the order openskill saw them.
"""

from __future__ import annotations

import itertools
import json
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from openskill.models import BradleyTerryFull

from ..agents.registry import KINDS, policy_names, resolve_policy
from ..game.records import read_jsonl
from .match import MatchSpec
from .records import GameRecord, game_record, write_records

RECORDS_DIR = "records"
LADDER_FILE = "ladder.json"
FILTERED = "_jitter_action"  # the variant of each learned policy a default ladder also rates
SCALE = 400 / (math.log(10) * math.sqrt(2))  # openskill's beta that puts mu on Elo's scale
BOOTSTRAP = 200
RANKS = {"win": [0, 1], "loss": [1, 0], "tie": [0, 0]}  # team A's result -> openskill ranks

Pair = tuple[str, str]


@dataclass(frozen=True)
class Ladder:
    """Which policies, how many games a pair, the seed of every pair's match and of the
    ratings' shuffles, and how many bootstrap replicates the intervals take."""

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

    def pairs(self) -> list[Pair]:
        return list(itertools.combinations(sorted(self.policies), 2))

    def match(self, pair: Pair) -> MatchSpec:
        return MatchSpec(pair[0], pair[1], self.games, self.seed)


def default_policies() -> list[str]:
    """Every policy in policies/ that plays in this process (scripted or learned, not remote),
    and each learned one also with both of the paper's filters (`FILTERED`)."""
    kinds = {name: resolve_policy(name).kind for name in policy_names()}
    local = [name for name, kind in kinds.items() if KINDS[kind].fixed is not None]
    return local + [name + FILTERED for name in local if KINDS[kinds[name]].fixed == "net"]


def pair_path(folder: Path, pair: Pair) -> Path:
    return folder / RECORDS_DIR / f"{pair[0]}__vs__{pair[1]}.jsonl"


def _read_pair(ladder: Ladder, path: Path, pair: Pair) -> list[GameRecord]:
    """The pair's records, refused (ValueError naming the file) unless they are exactly this
    ladder's games of this pair."""
    records = [game_record(row) for row in read_jsonl(path)]
    named = {(r.team, r.vs, tuple(r.filters)) for r in records}
    if named != {(pair[0], pair[1], ())}:
        raise ValueError(f"{path}: holds {sorted(named)[:2]}, not {pair[0]} vs {pair[1]}")
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
    """Write the pair's records whole: a temporary file, renamed once written."""
    path = pair_path(folder, pair)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(path.name + ".tmp")
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


def _games(ladder: Ladder, played: Mapping[Pair, Sequence[GameRecord]]):
    """Every game as (index of team A, index of team B, A's result), in the order of the
    ladder's pairs."""
    index = {name: k for k, name in enumerate(ladder.policies)}
    return [(index[a], index[b], record.result)
            for a, b in ladder.pairs() for record in played[(a, b)]]


def _rate_once(count: int, games: Sequence[tuple[int, int, str]],
               order: Iterable[int]) -> np.ndarray:
    """One online pass of openskill over `games` in `order`: the centred ratings (module
    docstring)."""
    model = BradleyTerryFull(mu=0.0, sigma=2 * SCALE, beta=SCALE, tau=0.0)
    ratings = [model.rating() for _ in range(count)]
    for k in order:
        a, b, result = games[k]
        [[ratings[a]], [ratings[b]]] = model.rate([[ratings[a]], [ratings[b]]],
                                                  ranks=RANKS[result])
    mu = np.array([rating.mu for rating in ratings])
    return mu - mu.mean()


def rate(ladder: Ladder, played: Mapping[Pair, Sequence[GameRecord]]) -> list[Standing]:
    """The ladder's standings, best first, from the played pairs' records (module docstring:
    the model, the scale and the bootstrap intervals)."""
    missing = [pair for pair in ladder.pairs() if pair not in played]
    if missing:
        raise ValueError(f"pair {missing[0][0]} vs {missing[0][1]} has not been played")
    policies = list(ladder.policies)
    games = _games(ladder, played)
    rng = np.random.default_rng(ladder.seed)
    ratings = _rate_once(len(policies), games, rng.permutation(len(games)))
    sizes = [len(played[pair]) for pair in ladder.pairs()]
    starts = np.cumsum([0, *sizes[:-1]])
    replicates = []
    for _ in range(ladder.bootstrap):
        drawn = np.concatenate([start + rng.integers(0, size, size)
                                for start, size in zip(starts, sizes, strict=True)])
        replicates.append(_rate_once(len(policies), games, rng.permutation(drawn)))
    low, high = np.percentile(np.array(replicates), [2.5, 97.5], axis=0)
    standings = []
    for k, name in enumerate(policies):
        results = [result if a == k else {"win": "loss", "loss": "win"}.get(result, result)
                   for a, b, result in games if k in (a, b)]
        standings.append(Standing(name, float(ratings[k]), float(low[k]), float(high[k]),
                                  len(results), results.count("win"), results.count("loss"),
                                  results.count("tie")))
    return sorted(standings, key=lambda s: -s.rating)


def write_ladder(path: Path, ladder: Ladder, standings: Sequence[Standing],
                 played: Mapping[Pair, Sequence[GameRecord]]) -> None:
    """The standings and each pair's results as JSON (a temporary file, renamed)."""
    pairs = [{"team": a, "vs": b, "games": len(played[(a, b)]),
              **{result: sum(r.result == result for r in played[(a, b)]) for result in RANKS}}
             for a, b in ladder.pairs()]
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
