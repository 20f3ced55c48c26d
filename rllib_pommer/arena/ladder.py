"""A ladder: one Elo-like rating per named policy, from round-robin arena matches.

Pairs. Every unordered pair of the ladder's policies plays one match: the two names in sorted
order as team A and team B (so a ladder does not depend on the order its policies are listed in),
`games` games with seats balanced (the arena's default: team A on seats {0, 2} in even games and
{1, 3} in odd ones, so `games` must be even) and the ladder's seed. A name may carry the
registry's filter suffixes (`ppo_team_jitter_action`): a filtered policy is a policy of its own
on the ladder.

Records. Each pair's games are an arena records file, `<folder>/records/<a>__vs__<b>.jsonl.gz` (the
rows `evaluate --records` writes, which name their match), written whole when the pair's match
ends (a temporary file renamed), so an interrupted ladder keeps every pair it finished. Beside
them `records/played.json` keeps the games a pair and the seed they were played with and a
digest of what each policy plays (`policy_digest`: its file's keys and its weights), written
before the first game. A pair whose file holds games 0..games-1 of the ladder's seed is played
and never played again. Everything else is refused before any game, naming the file or the
policy, and never mixed into the ratings: a ladder asking for other games or another seed than
its folder's, a pair file with a game missing or repeated (cut short or damaged), and the pairs
of a policy whose digest changed since they were played (new weights, `greedy = true` added):
their games are not what the policy now plays. A folder without `played.json` takes its games
and seed from its `ladder.json` (or, lacking that too, from the ladder asked for) and its
policies as they are now. Adding a policy adds only its pairs.

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

import hashlib
import itertools
import json
import math
import os
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import choix
import numpy as np

from ..agents.registry import KINDS, policy_names, resolve_policy
from .match import MatchSpec
from .records import RECORDS_SUFFIX, GameRecord, read_records, write_records

RECORDS_DIR = "records"
PLAYED_FILE = "played.json"  # in RECORDS_DIR: the games, seed and digests pairs were played with
LADDER_FILE = "ladder.json"
PLAIN_LADDER_FILE = "ladder_no_filters.json"  # the fit over the policies without filters
VERSUS = "__vs__"  # between the two names of a pair's file
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
        if self.games % 2:
            raise ValueError(f"games a pair must be even, so that each policy plays half of "
                             f"them on seats {{0, 2}} and half on {{1, 3}}; got {self.games}")
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

    def without_filters(self) -> Ladder | None:
        """The same ladder over its policies that play without the paper's filters (no filter
        suffix in their names): a second view in which a top place cannot come from a filtered
        variant of the same agent. None when fewer than two are left."""
        plain = tuple(name for name in self.policies if not resolve_policy(name).filters)
        return replace(self, policies=plain) if len(plain) >= 2 else None


def default_policies() -> list[str]:
    """Every policy in policies/ that plays in this process (scripted or learned, not remote),
    and each learned one also with both of the paper's filters (`FILTERED`)."""
    kinds = {name: resolve_policy(name).kind for name in policy_names()}
    local = [name for name, kind in kinds.items() if KINDS[kind].fixed is not None]
    return local + [name + FILTERED for name in local if KINDS[kinds[name]].fixed == "net"]


def pair_path(folder: Path, pair: Pair) -> Path:
    return folder / RECORDS_DIR / f"{pair[0]}{VERSUS}{pair[1]}{RECORDS_SUFFIX}"


def policy_digest(name: str) -> str:
    """What the policy `name` plays, as a SHA-256 hex digest: its kind, every key of its file
    but the description, and the bytes of each file or folder a key names beside the policy
    file (its weights, a checkpoint). New weights or an added `greedy = true` change it, a
    reworded description does not; a filter suffix is not part of it (the name is)."""
    spec = resolve_policy(name)
    digest = hashlib.sha256(json.dumps([spec.kind, spec.params], sort_keys=True).encode())
    paths = [spec.file(key) for key, value in sorted(spec.params.items())
             if isinstance(value, str)]
    for path in (path for path in paths if path.exists()):
        files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
        for file in files:
            digest.update(file.relative_to(path.parent).as_posix().encode() + b"\0"
                          + file.read_bytes())
    return digest.hexdigest()


def _read_pair(ladder: Ladder, path: Path, pair: Pair) -> list[GameRecord]:
    """The pair's records, refused (ValueError naming the file) unless they are exactly this
    ladder's games of this pair."""
    records = read_records(path)
    named = {(r.team, r.vs, tuple(r.filters)) for r in records}
    if named != {(pair[0], pair[1], ())}:
        raise ValueError(f"{path}: holds {sorted(named)[:2]}, not {pair[0]} vs {pair[1]}")
    unknown = [r for r in records if r.result not in RESULTS]
    if unknown:
        raise ValueError(f"{path}: game {unknown[0].game}: result {unknown[0].result!r} is not "
                         f"one of {list(RESULTS)}")
    seeds = sorted({r.seed for r in records})
    if seeds != [ladder.seed]:
        raise ValueError(f"{path}: games of seed {', '.join(map(str, seeds))}, where this ladder "
                         f"plays seed {ladder.seed}: resume with the --seed they were played "
                         f"with, or use another --out (never mixed in one ladder)")
    counts = Counter(r.game for r in records)
    repeated = sorted(game for game, count in counts.items() if count > 1)
    expected = set(range(ladder.games))
    odd = sorted(set(counts) ^ expected)
    if repeated or odd:
        wrong = (f"game {repeated[0]} appears {counts[repeated[0]]} times" if repeated else
                 f"game {odd[0]} is {'missing' if odd[0] in expected else 'not one of them'}")
        raise ValueError(f"{path}: the pair plays games 0..{ladder.games - 1} and {wrong}: the "
                         f"file is cut short or damaged; delete it to play the pair again")
    return sorted(records, key=lambda r: r.game)


def _kept_settings(folder: Path) -> dict | None:
    """The games, seed and policy digests (name -> digest) the folder's pairs were played
    with: `played.json`, else `ladder.json`'s games and seed with no digests (module
    docstring); None for a folder with neither."""
    played, finished = folder / RECORDS_DIR / PLAYED_FILE, folder / LADDER_FILE
    if played.is_file():
        try:
            kept = json.loads(played.read_text())
            if not isinstance(kept["policies"], dict):
                raise TypeError("policies is not a table of digests")
            return {"games": int(kept["games"]), "seed": int(kept["seed"]),
                    "policies": kept["policies"]}
        except (ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"{played}: not a ladder's {PLAYED_FILE} ({exc!r}); delete it to "
                             f"take the records as played with this ladder's settings and "
                             f"policies") from None
    if finished.is_file():
        data, _ = read_ladder(finished)
        return {"games": data["games_per_pair"], "seed": data["seed"], "policies": {}}
    return None


def _pair_files(folder: Path, name: str | None = None) -> list[Path]:
    """The records files of the pairs played in `folder` (this ladder's or not; with `name`,
    those of its pairs)."""
    return sorted(path for path in (folder / RECORDS_DIR).glob(f"*{RECORDS_SUFFIX}")
                  if not path.name.startswith(".") and (
                      name is None or name in path.name.removesuffix(RECORDS_SUFFIX).split(VERSUS)))


def _check_unchanged(folder: Path, kept: Mapping[str, str], digests: Mapping[str, str]) -> None:
    """Refuse, naming it, a policy whose pairs in `folder` were played while its digest was
    another than it is now."""
    for name, digest in digests.items():
        files = _pair_files(folder, name) if kept.get(name, digest) != digest else []
        if files:
            raise ValueError(
                f"policy {name!r} changed since its pairs in {folder / RECORDS_DIR} were played "
                f"(its file's keys or weights differ from the digest {PLAYED_FILE} keeps), so "
                f"their games are not its play now: delete its {len(files)} pair files "
                f"({files[0].name}, ...) to play them again, or use another --out")


def resume(ladder: Ladder, folder: Path) -> dict[Pair, list[GameRecord]]:
    """The ladder's pairs already played in `folder`, every file checked before any game
    (module docstring: what is refused); then `played.json` keeps this ladder's games, seed
    and policy digests for the pairs still to play."""
    asked = {"games": ladder.games, "seed": ladder.seed, "policies": {}}
    kept = _kept_settings(folder) or asked
    if (kept["games"], kept["seed"]) != (asked["games"], asked["seed"]) and _pair_files(folder):
        raise ValueError(
            f"{folder}: its pairs were played with --games {kept['games']} --seed "
            f"{kept['seed']}, and this ladder asks for --games {ladder.games} --seed "
            f"{ladder.seed}: resume with the same --games and --seed, or use another --out "
            f"(never mixed in one ladder)")
    played = {pair: _read_pair(ladder, pair_path(folder, pair), pair)
              for pair in ladder.pairs() if pair_path(folder, pair).is_file()}
    digests = {name: policy_digest(name) for name in ladder.policies}
    _check_unchanged(folder, kept["policies"], digests)
    path = folder / RECORDS_DIR / PLAYED_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps({**asked, "policies": {**kept["policies"], **digests}}, indent=1,
                      sort_keys=True)
    _write_whole(path, lambda temporary: temporary.write_text(text + "\n"))
    return played


def _write_whole(path: Path, write: Callable[[Path], object]) -> None:
    """`write` fills a temporary file beside `path` (a hidden name of the same kind), renamed
    to `path` once written: an interrupted write leaves the old file, never half a new one."""
    temporary = path.with_name(".writing-" + path.name)
    write(temporary)
    os.replace(temporary, path)


def save_pair(folder: Path, pair: Pair, records: Sequence[GameRecord]) -> Path:
    """Write the pair's records whole (`_write_whole`)."""
    path = pair_path(folder, pair)
    path.parent.mkdir(parents=True, exist_ok=True)
    _write_whole(path, lambda temporary: write_records(temporary, records))
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
    """The standings and each pair's results as JSON, written whole (`_write_whole`)."""
    pairs = [{"team": a, "vs": b, "games": int(row.sum()),
              **{result: int(count) for result, count in zip(RESULTS, row, strict=True)}}
             for (a, b), row in zip(ladder.pairs(), _results(ladder, played), strict=True)]
    data = {"policies": list(ladder.policies), "games_per_pair": ladder.games,
            "seed": ladder.seed, "bootstrap": ladder.bootstrap,
            "standings": [asdict(s) for s in standings], "pairs": pairs}
    _write_whole(path, lambda temporary: temporary.write_text(json.dumps(data, indent=1) + "\n"))


def read_ladder(path: Path) -> tuple[dict, list[Standing]]:
    """A ladder file's settings (games_per_pair, seed, bootstrap, policies) and standings."""
    try:
        data = json.loads(path.read_text())
        standings = [Standing(**row) for row in data.pop("standings")]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{path}: not a ladder file ({exc})") from None
    return data, standings
