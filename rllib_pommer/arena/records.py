"""What a match's games did, seen from team A: one record per game, the match's summary with
95% intervals, and the records file `evaluate --records` writes and the report, the ladder and
the tables read: its writer (`write_records`) and its readers (`read_rows`, `read_records`)."""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..game.constants import TEAM_PRESET
from ..game.kills import deaths_by_cause, kills_of_team
from ..game.records import JSONL_SUFFIXES, numbered_values, open_text
from .rates import wilson

# The name ending of the record files the project's own jobs write (tables, ladder): gzipped
# JSON Lines, about a twentieth of the plain size.
RECORDS_SUFFIX = ".jsonl.gz"
# The kinds of records file written and read: JSON Lines (plain or gzipped) and .csv.
RECORDS_SUFFIXES = (*JSONL_SUFFIXES, ".csv")


@dataclass
class GameRecord:
    """What one game did, seen from team A."""

    game: int
    seed: int
    seats_a: list[int]
    result: str  # "win", "loss" or "tie" for team A
    length: int
    died: list[bool]  # by seat
    own_bomb_deaths: list[bool]  # by seat: died in fire its own bomb was part of (engine credit)
    bombs_laid: list[int]  # by seat, as the engine counts them
    # The match, so a records file names what it holds (the report reads it from the rows).
    team: str = ""
    vs: str = ""
    filters: list[str] = field(default_factory=list)
    # By seat, the seats whose fire it died in (game/kills.py); [] for the living. None in
    # records written before the engine credited kills.
    killers: list[list[int]] | None = None
    # The game's preset: "team", or "radio" (TeamRadio, docs/rules.md §10).
    variant: str = "team"

    def kill_counts(self) -> dict[str, int] | None:
        """Per team ("a", "b"): enemies it killed, its own agents' suicides (an own bomb among
        the fire they died in) and team kills; None without kill credit."""
        if self.killers is None:
            return None
        masks = [sum(1 << k for k in seats) for seats in self.killers]
        counts = {}
        for side, seats in (("a", self.seats_a),
                            ("b", [s for s in range(4) if s not in self.seats_a])):
            causes = deaths_by_cause(seats, self.died, masks)
            counts[f"kills_{side}"] = kills_of_team(seats[0], self.died, masks)
            counts[f"suicides_{side}"] = causes["self"]
            counts[f"team_kills_{side}"] = causes["teammate"]
        return counts


KILL_COUNTS = tuple(f"{what}_{side}" for what in ("kills", "suicides", "team_kills")
                    for side in ("a", "b"))


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
    # How the games ended: deaths per agent and how many by the agent's own bomb, the losses
    # in which every agent of A died by its own bomb, and the ties the step limit decided.
    for side, seats in (("a", a_seats), ("b", b_seats)):
        out[f"dead_per_agent_{side}"] = sum(r.died[s] for r, s in seats) / len(seats)
        out[f"own_bomb_dead_per_agent_{side}"] = sum(
            r.own_bomb_deaths[s] for r, s in seats) / len(seats)
    out["loss_own_bombs_only"] = sum(
        r.result == "loss" and all(r.own_bomb_deaths[s] for s in r.seats_a) for r in records) / n
    out["tie_at_step_limit"] = sum(
        r.result == "tie" and r.length >= TEAM_PRESET.max_steps for r in records) / n
    counts = [r.kill_counts() for r in records]
    if all(c is not None for c in counts):  # per game, with 95% intervals
        for key in KILL_COUNTS:
            values = np.array([c[key] for c in counts], float)
            out[f"{key}_per_game"] = float(values.mean())
            out[f"{key}_per_game_ci95"] = _mean_ci(values)
    return out


def _mean_ci(values: np.ndarray) -> list[float]:
    half = 1.96 * values.std(ddof=1) / math.sqrt(len(values)) if len(values) > 1 else math.inf
    return [float(values.mean() - half), float(values.mean() + half)]


LIST_COLUMNS = ("seats_a", "died", "own_bomb_deaths", "bombs_laid", "filters", "killers")


def game_record(row: dict) -> GameRecord:
    """A records file's row (`read_rows`: list columns of a .csv are JSON text) as the
    GameRecord it was written from."""
    fields = {k: _list_column(v) if k in LIST_COLUMNS and isinstance(v, str) else v
              for k, v in row.items()}
    return GameRecord(**{**fields, "game": int(fields["game"]), "seed": int(fields["seed"]),
                         "length": int(fields["length"])})


def _list_column(text: str) -> list | None:
    """A list column of a .csv row: JSON text, or empty for a column the game had no value in
    (`killers` of records without kill credit)."""
    return json.loads(text) if text else None


def record_rows(records: Sequence[GameRecord]) -> Iterator[dict]:
    for record in records:
        yield asdict(record)


def write_records(path: Path, records: Sequence[GameRecord]) -> None:
    """The rows of `record_rows` as a .csv file (lists as JSON) or, for any other suffix, JSON
    Lines (gzipped for .gz)."""
    rows = list(record_rows(records))
    if path.suffix == ".csv":
        with open(path, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows({k: json.dumps(v) if isinstance(v, list) else v
                              for k, v in row.items()} for row in rows)
    else:
        with open_text(path, "w") as f:
            f.writelines(json.dumps(row) + "\n" for row in rows)


def read_rows(path: Path) -> list[dict]:
    """Rows of a .jsonl, .jsonl.gz or .csv records file as written (list columns of a .csv are
    JSON text; files of older versions may lack columns); a line that is not a JSON object is a
    ValueError naming the file and line."""
    if path.suffix == ".csv":
        with open(path, newline="") as f:
            return list(csv.DictReader(f))
    rows = []
    for line_no, row in numbered_values(path):
        if not isinstance(row, dict):
            raise ValueError(f"{path}:{line_no}: a records row is a JSON object, got "
                             f"{type(row).__name__}")
        rows.append(row)
    return rows


def read_records(path: Path) -> list[GameRecord]:
    """The GameRecords of a records file (`read_rows`); a row without a column every record has
    (or with one no record has) is a ValueError naming the file."""
    try:
        return [game_record(row) for row in read_rows(path)]
    except (KeyError, TypeError) as exc:
        raise ValueError(f"{path}: not an arena records file (no {exc})") from None
