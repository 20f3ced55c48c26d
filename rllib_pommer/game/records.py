"""Game records in the reference's JSON Lines schema: read, record while playing, write.

A record holds `initial_state` and, per step, the actions and the resulting state, rewards, done,
info and (optionally) the four observations, so any recorded position can be reloaded and replayed.
A TeamRadio record also holds, per step, `full_actions`: each agent's action as passed, a move or
[move, word, word] (`actions` keeps the moves alone); its states carry `radio_from_agent` and its
observations `message`.
"""

from __future__ import annotations

import gzip
import io
import json
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from .constants import CONFIG_BY_ENV_ID, NUM_AGENTS, GameConfig, Result
from .engine import Games, info_dict, radio_actions
from .serialize import dump_observation


class _StamplessGzip(gzip.GzipFile):
    """A gzip file written with neither a name nor a time in its header, so the same lines give
    the same bytes whatever the file is called (a temporary name, renamed) and whenever; it
    closes the file it writes into."""

    def __init__(self, path: Path):
        # The raw file lives as long as this object and is closed by close(), not by a with-block.
        raw = open(path, "wb")  # noqa: SIM115
        super().__init__(filename="", mode="wb", fileobj=raw, mtime=0)
        self._owned = raw

    def close(self) -> None:
        try:
            super().close()
        finally:
            self._owned.close()


# The names a JSON Lines file of game records takes: plain, or gzipped (`open_text`).
JSONL_SUFFIXES = (".jsonl", ".jsonl.gz")


def open_text(path: Path, mode: str):
    """A .jsonl file, or a .jsonl.gz one through gzip, opened as text for `mode` ("r", "w")."""
    if path.suffix != ".gz":
        return open(path, mode)
    if mode == "r":
        return gzip.open(path, "rt")
    return io.TextIOWrapper(_StamplessGzip(path), encoding="utf-8")


def name_stem(path: Path) -> str:
    """A data file's name without its kind: `a__vs__b` for a.jsonl, a.jsonl.gz or a.csv."""
    name = path.name.removesuffix(".gz")
    return name[: -len(Path(name).suffix)] if Path(name).suffix else name


# What every step of a record holds (the observations are optional: `has_observations`).
STEP_FIELDS = ("actions", "state", "rewards", "done", "info")


def check_record(record, where: str) -> dict:
    """`record` if it has the fields replaying and drawing it need, else a ValueError naming
    `where` and the field (the states' contents are checked where they are loaded)."""
    if not isinstance(record, dict):
        raise ValueError(f"{where}: a game record must be a JSON object, got "
                         f"{type(record).__name__}")
    for key, kind in (("initial_state", dict), ("steps", list)):
        if key not in record:
            raise ValueError(f"{where}: missing field {key!r}")
        if not isinstance(record[key], kind):
            raise ValueError(f"{where}: field {key!r} must be a JSON {kind.__name__}")
    for t, step in enumerate(record["steps"]):
        missing = [key for key in STEP_FIELDS if not isinstance(step, dict) or key not in step]
        if missing:
            raise ValueError(f"{where}: steps[{t}]: missing field {missing[0]!r}")
        if not isinstance(step["state"], dict):
            raise ValueError(f"{where}: steps[{t}].state must be a JSON object")
    return record


def numbered_values(path: str | Path) -> Iterator[tuple[int, object]]:
    """(line number, JSON value) of each non-blank line of a .jsonl or .jsonl.gz file; errors
    as `read_jsonl`'s."""
    path = Path(path)
    if not path.exists():
        raise ValueError(f"{path}: no such file")
    line_no = 0
    try:
        with open_text(path, "r") as f:
            for line_no, line in enumerate(f, 1):
                if not line.strip():
                    continue
                try:
                    yield line_no, json.loads(line)
                except json.JSONDecodeError as exc:
                    raise ValueError(f"{path}:{line_no}: not JSON ({exc})") from None
    except (EOFError, OSError, UnicodeDecodeError) as exc:  # a gzip cut short, or not gzip
        raise ValueError(f"{path}: damaged or cut short after {line_no} lines ({exc})") from None


def read_jsonl(path: str | Path) -> Iterator:
    """Yield the JSON values of a .jsonl or .jsonl.gz file, one a line; ValueError naming the
    file (and line) for a missing file, one cut short or damaged, or a line that is not JSON."""
    return (value for _, value in numbered_values(path))


def read_games(path: str | Path) -> Iterator[dict]:
    """Yield the game records of a .jsonl or .jsonl.gz file, one at a time, each checked by
    `check_record` (errors name the file and line)."""
    for line_no, record in numbered_values(path):
        yield check_record(record, f"{path}:{line_no}")


def write_games(path: str | Path, records: Iterable[dict]) -> int:
    """Write records as JSON Lines (gzip if the name ends in .gz); return how many."""
    path = Path(path)
    count = 0
    with open_text(path, "w") as f:
        for record in records:
            f.write(json.dumps(record, separators=(",", ":")) + "\n")
            count += 1
    return count


def observation_dicts(games: Games, index: int) -> list[dict]:
    """The four current observations of game `index` as reference dicts (with `message` in
    TeamRadio)."""
    obs = games.obs
    message = games.message[index] if games.radio else [None] * NUM_AGENTS
    return [dump_observation(obs.select(index, a), message[a]) for a in range(NUM_AGENTS)]


def full_actions(actions) -> list:
    """One game's actions as a TeamRadio record's `full_actions`: a move stays an int, a
    [move, word, word] a list (validated by `engine.radio_actions`)."""
    rows = radio_actions(actions)
    return [int(row[0]) if np.ndim(action) == 0 else row.tolist()
            for row, action in zip(rows, actions, strict=True)]


def config_of(record: dict) -> GameConfig:
    env_id = record.get("env_id")
    if env_id not in CONFIG_BY_ENV_ID:
        valid = sorted(CONFIG_BY_ENV_ID)
        raise ValueError(f"game record: unknown env_id {env_id!r}; valid: {valid}")
    return CONFIG_BY_ENV_ID[env_id]


class GameRecorder:
    """Builds one record while game `index` of a `Games` batch is played (a `Game` is a batch of
    one: pass `game.batch`); call `start` after the reset and `step` after each step."""

    def __init__(self, games: Games, index: int, seed: int, agent_mix: str = "",
                 with_observations: bool = True):
        self.games = games
        self.index = index
        self.with_observations = with_observations
        self.record: dict = {
            "env_id": games.config.env_id,
            "seed": seed,
            "agent_mix": agent_mix,
            "initial_state": games.dump(index),
            "has_observations": with_observations,
            "steps": [],
        }

    def start(self) -> None:
        if self.with_observations:
            self.record["initial_observations"] = observation_dicts(self.games, self.index)

    def step(self, actions) -> None:
        """Record the step just played with `actions` (this game's four, as passed)."""
        n = self.index
        rewards = self.games.rewards[n]
        if self.games.radio:
            full = full_actions(actions)
            moves = [a if isinstance(a, int) else a[0] for a in full]
        else:
            moves = [int(a) for a in actions]
        entry = {
            "actions": moves,
            **({"full_actions": full} if self.games.radio else {}),
            "state": self.games.dump(n),
            "rewards": [int(r) for r in rewards],
            "done": bool(self.games.done[n]),
            "info": info_dict(int(self.games.results[n]), rewards),
        }
        if self.with_observations:
            entry["observations"] = observation_dicts(self.games, n)
        self.record["steps"].append(entry)

    def finish(self) -> dict:
        steps = self.record["steps"]
        self.record["num_steps"] = len(steps)
        self.record["final_info"] = (steps[-1]["info"] if steps
                                     else info_dict(Result.INCOMPLETE, np.zeros(NUM_AGENTS)))
        return self.record
