"""Arena record files (`evaluate --records`, one row per game) and which match each one holds.

A file's match comes from, first found:

1. a sidecar `<file without suffix>.json` holding evaluate's `--json` summary line, whose keys
   `team`, `vs` and `filters` are used (`evaluate ... --records m.jsonl --json | tail -1 > m.json`;
   it may rename a team, as `benchmarks/paper_table.py` does);
2. the rows themselves: their `team`, `vs` and `filters` columns, which `evaluate --records`
   writes (all rows of a file must agree);
3. the file name `<team>[+<filter>...]__vs__<opponent>.jsonl` (or `.jsonl.gz`, `.csv`), e.g.
   `ppo+jitter+action__vs__simple_nobomb.jsonl`, for records written before the rows named it.

A team name may also carry the registry's filter suffixes (`ppo_jitter_action`); they count as
filters. The variant of a match is its filter set in the paper's column names: `vanilla`,
`jitter`, `action` or `jitter_action`.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from ..agents.registry import FILTER_SUFFIXES, FILTERS
from ..arena.rates import wilson
from ..arena.records import KILL_COUNTS, game_record, read_rows
from ..game.records import name_stem

VARIANTS = ("vanilla", "jitter", "action", "jitter_action")
NAME_SEPARATOR = "__vs__"
ROW_KEYS = frozenset({"game", "seats_a", "result"})


@dataclass(frozen=True)
class Match:
    """Which match a record file holds: our team, its filter variant and the opponent."""
    team: str  # policy name without filters
    variant: str  # one of VARIANTS
    vs: str


@dataclass
class Outcomes:
    """Team A's results over `games` games, and who killed whom in the `credited` of them whose
    records carry kill credit (sums of `GameRecord.kill_counts` and of A's bombs laid)."""

    win: int = 0
    loss: int = 0
    tie: int = 0
    credited: int = 0
    kill_sums: dict[str, int] = field(default_factory=lambda: dict.fromkeys(KILL_COUNTS, 0))
    bombs_a: int = 0

    @property
    def games(self) -> int:
        return self.win + self.loss + self.tie

    def rates(self) -> tuple[float, float, float]:
        return self.win / self.games, self.loss / self.games, self.tie / self.games

    def intervals(self) -> tuple[tuple[float, float], ...]:
        """95% Wilson intervals of the win, loss and tie rates, each within [0, 1]."""
        return tuple(wilson(k, self.games) for k in (self.win, self.loss, self.tie))

    def per_game(self) -> dict[str, float] | None:
        """Kill counts per game (KILL_COUNTS) and A's bombs per agent per game, or None when no
        record carried kill credit."""
        if not self.credited:
            return None
        out = {key: value / self.credited for key, value in self.kill_sums.items()}
        out["bombs_per_agent_a"] = self.bombs_a / (2 * self.credited)
        return out

    def add(self, row: dict) -> None:
        """Count one records row (at least ROW_KEYS; kill credit where it has `killers`)."""
        setattr(self, row["result"], getattr(self, row["result"]) + 1)
        if row.get("killers") not in (None, ""):
            record = game_record(row)
            counts = record.kill_counts()
            self.credited += 1
            for key, value in counts.items():
                self.kill_sums[key] += value
            self.bombs_a += sum(record.bombs_laid[s] for s in record.seats_a)


def variant_of(team: str, filters: Iterable[str]) -> tuple[str, str]:
    """(base policy name, variant) of a team name and its extra filters."""
    wanted = set(filters)
    for suffix, suffix_filters in FILTER_SUFFIXES.items():  # longest suffix first
        if team.endswith(suffix):
            team, wanted = team[: -len(suffix)], wanted | set(suffix_filters)
            break
    unknown = wanted - set(FILTERS)
    if unknown:
        raise ValueError(f"unknown filter(s) {sorted(unknown)}; valid: {list(FILTERS)}")
    return team, "_".join(f for f in FILTERS if f in wanted) or "vanilla"


def _named_by_rows(path: Path, rows: list[dict]) -> tuple[str, str, list[str]] | None:
    """(team, vs, filters) from the rows' own columns, or None if they do not name them."""
    names = {(row.get("team") or "", row.get("vs") or "",
              json.dumps(_listed(row.get("filters") or []))) for row in rows}
    if len(names) > 1:
        raise ValueError(f"{path}: rows of more than one match {sorted(names)[:2]}; "
                         f"write one match per file")
    team, vs, filters = names.pop() if names else ("", "", "[]")
    return (team, vs, json.loads(filters)) if team and vs else None


def _listed(value) -> list:
    """A list column: a list in .jsonl, its JSON text in .csv."""
    return json.loads(value) if isinstance(value, str) else list(value)


def match_of(path: Path, rows: list[dict] | None = None) -> Match:
    """The match of a records file (module docstring); `rows`: its rows, if already read."""
    sidecar = path.with_name(name_stem(path) + ".json")
    if sidecar.is_file():
        lines = sidecar.read_text().strip().splitlines()
        try:
            summary = json.loads(lines[-1])
        except (IndexError, json.JSONDecodeError) as exc:
            raise ValueError(f"{sidecar}:{len(lines)}: not an evaluate --json summary "
                             f"({exc})") from None
        if not isinstance(summary, dict) or not {"team", "vs"} <= set(summary):
            raise ValueError(f"{sidecar}: an evaluate --json summary needs 'team' and 'vs'")
        team, vs, filters = summary["team"], summary["vs"], summary.get("filters", [])
    elif named := _named_by_rows(path, read_rows(path) if rows is None else rows):
        team, vs, filters = named
    elif NAME_SEPARATOR in name_stem(path):
        left, vs = name_stem(path).split(NAME_SEPARATOR, 1)
        team, *filters = left.split("+")
    else:
        raise ValueError(f"{path}: cannot tell which match it holds (its rows have no team "
                         f"and vs: written by an older evaluate?); add a sidecar "
                         f"{sidecar.name} (evaluate --json) or name it "
                         f"<team>[+<filter>...]{NAME_SEPARATOR}<opponent>"
                         f"{path.name.removeprefix(name_stem(path))}")
    base, variant = variant_of(team, filters)
    return Match(base, variant, vs)


def load_outcomes(paths: Iterable[Path]) -> dict[Match, Outcomes]:
    """Team A's results per match, over all the files of each match."""
    results: dict[Match, Outcomes] = {}
    # A game is its match, match seed, game index and seats: (seed, index) deal the board and
    # every random stream (arena/match.py), so a second row of it is the same game again. Rows
    # without a seed (older files) are compared within their file only.
    seen: dict[tuple, Path] = {}
    for path in paths:
        rows = read_rows(path)
        match = match_of(path, rows)
        outcomes = results.setdefault(match, Outcomes())
        for row in rows:
            game = (match, str(row.get("game")), str(row.get("seed", path)),
                    str(row.get("seats_a")))
            if game in seen:
                raise ValueError(f"{path}: game {game[1]} (seed {game[2]}) of {match.team} vs "
                                 f"{match.vs} appears twice (also in {seen[game]}); each game "
                                 f"counts once: remove the duplicated rows or files")
            seen[game] = path
            if row["result"] not in ("win", "loss", "tie"):
                raise ValueError(f"{path}: result {row['result']!r} is not win, loss or tie")
            outcomes.add(row)
    return results


def rates_by_opponent(results: dict[Match, Outcomes],
                      team: str) -> dict[str, dict[str, tuple[float, float, float]]]:
    """Team `team`'s (win, loss, tie) rates by opponent and variant."""
    table: dict[str, dict[str, tuple[float, float, float]]] = {}
    for match, outcomes in results.items():
        if match.team == team and outcomes.games:
            table.setdefault(match.vs, {})[match.variant] = outcomes.rates()
    return table
