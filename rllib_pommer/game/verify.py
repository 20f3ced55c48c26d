"""Replay recorded games through our engine and compare every step with the recording.

The comparison covers the full state (board, hidden items in order, agents, bombs and flames in
list order, and in TeamRadio each agent's last words), rewards, done, info and all four
observations (with `message` in TeamRadio). A TeamRadio record is replayed with its
`full_actions`, which carry the words. On a mismatch the game is re-synced to
the recorded state, so one divergence is reported once and the rest of the game is still checked.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

from .engine import Game
from .records import config_of, observation_dicts


@dataclass
class Mismatch:
    seed: int
    step: int
    field: str
    expected: object
    actual: object

    def __str__(self) -> str:
        return (f"game seed {self.seed} step {self.step}: {self.field}: "
                f"expected {self.expected!r:.200} got {self.actual!r:.200}")


@dataclass
class VerifyReport:
    games: int = 0
    steps: int = 0
    mismatches: list[Mismatch] = field(default_factory=list)

    def summary(self) -> str:
        return f"verified {self.games} games, {self.steps} steps, {len(self.mismatches)} mismatches"


def first_difference(expected, actual, path: str) -> tuple[str, object, object] | None:
    """The path of the first differing leaf of two JSON-like values, with both leaves."""
    if isinstance(expected, dict) and isinstance(actual, dict):
        for key in expected.keys() | actual.keys():
            if key not in actual or key not in expected:
                return f"{path}.{key}", expected.get(key), actual.get(key)
            diff = first_difference(expected[key], actual[key], f"{path}.{key}")
            if diff:
                return diff
        return None
    if isinstance(expected, list) and isinstance(actual, list):
        if len(expected) != len(actual):
            return f"{path} (length)", len(expected), len(actual)
        for i, (e, a) in enumerate(zip(expected, actual, strict=True)):
            diff = first_difference(e, a, f"{path}[{i}]")
            if diff:
                return diff
        return None
    return None if expected == actual else (path, expected, actual)


def _compare(expected, actual, seed, step, name) -> Iterator[Mismatch]:
    if expected != actual:
        diff = first_difference(expected, actual, name) or (name, expected, actual)
        yield Mismatch(seed, step, *diff)


def verify_game(record: dict) -> tuple[int, list[Mismatch]]:
    """Replay one record; return its step count and mismatches."""
    seed = record.get("seed")
    game = Game.from_state(record["initial_state"], config_of(record))
    mismatches: list[Mismatch] = []
    for t, entry in enumerate(record["steps"]):
        _, rewards, done, info = game.step(entry.get("full_actions", entry["actions"]))
        found = [
            *_compare(entry["state"], game.dump(), seed, t, "state"),
            *_compare(entry["rewards"], [int(r) for r in rewards], seed, t, "rewards"),
            *_compare(entry["done"], done, seed, t, "done"),
            *_compare(entry["info"], info, seed, t, "info"),
        ]
        if "observations" in entry:
            actual = observation_dicts(game.batch, 0)
            for a, expected in enumerate(entry["observations"]):
                found.extend(_compare(expected, actual[a], seed, t, f"observations[{a}]"))
        if found:
            mismatches.extend(found)
            game.load(entry["state"])
        if done and t + 1 < len(record["steps"]):
            mismatches.append(Mismatch(seed, t, "done", False, True))
            break
    return len(record["steps"]), mismatches


def verify_games(records: Iterable[dict]) -> VerifyReport:
    report = VerifyReport()
    for record in records:
        steps, mismatches = verify_game(record)
        report.games += 1
        report.steps += steps
        report.mismatches.extend(mismatches)
    return report
