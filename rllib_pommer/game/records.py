"""Game records in the reference's JSON Lines schema: read, record while playing, write.

A record holds `initial_state` and, per step, the actions and the resulting state, rewards, done,
info and (optionally) the four observations, so any recorded position can be reloaded and replayed.
"""

from __future__ import annotations

import gzip
import json
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from .constants import CONFIG_BY_ENV_ID, NUM_AGENTS, GameConfig, Result
from .engine import Games, info_dict
from .serialize import dump_observation


def _open(path: Path, mode: str):
    return gzip.open(path, mode + "t") if path.suffix == ".gz" else open(path, mode)


def read_games(path: str | Path) -> Iterator[dict]:
    """Yield the game records of a .jsonl or .jsonl.gz file, one at a time."""
    path = Path(path)
    if not path.exists():
        raise ValueError(f"{path}: no such file")
    with _open(path, "r") as f:
        for line_no, line in enumerate(f, 1):
            if not line.strip():
                continue
            try:
                yield json.loads(line)
            except json.JSONDecodeError as exc:
                raise ValueError(f"{path}:{line_no}: not a JSON game record ({exc})") from None


def write_games(path: str | Path, records: Iterable[dict]) -> int:
    """Write records as JSON Lines (gzip if the name ends in .gz); return how many."""
    path = Path(path)
    count = 0
    with _open(path, "w") as f:
        for record in records:
            f.write(json.dumps(record, separators=(",", ":")) + "\n")
            count += 1
    return count


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

    def _observations(self) -> list[dict]:
        obs = self.games.obs
        return [dump_observation(obs.select(self.index, a)) for a in range(NUM_AGENTS)]

    def start(self) -> None:
        if self.with_observations:
            self.record["initial_observations"] = self._observations()

    def step(self, actions) -> None:
        n = self.index
        rewards = self.games.rewards[n]
        entry = {
            "actions": [int(a) for a in actions],
            "state": self.games.dump(n),
            "rewards": [int(r) for r in rewards],
            "done": bool(self.games.done[n]),
            "info": info_dict(int(self.games.results[n]), rewards),
        }
        if self.with_observations:
            entry["observations"] = self._observations()
        self.record["steps"].append(entry)

    def finish(self) -> dict:
        steps = self.record["steps"]
        self.record["num_steps"] = len(steps)
        self.record["final_info"] = (steps[-1]["info"] if steps
                                     else info_dict(Result.INCOMPLETE, np.zeros(NUM_AGENTS)))
        return self.record
