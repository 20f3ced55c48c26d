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

from .constants import CONFIG_BY_ENV_ID, GameConfig
from .engine import Game, info_dict
from .observation import Observation
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


def _observations(obs: Observation) -> list[dict]:
    return [dump_observation(obs.select(a)) for a in range(obs.board.shape[0])]


class GameRecorder:
    """Builds one record while a `Game` is played; call `step` after each `Game.step`."""

    def __init__(self, game: Game, seed: int, agent_mix: str = "", with_observations=True):
        self.game = game
        self.with_observations = with_observations
        self.record: dict = {
            "env_id": game.config.env_id,
            "seed": seed,
            "agent_mix": agent_mix,
            "initial_state": game.dump(),
            "has_observations": with_observations,
            "steps": [],
        }

    def start(self, obs: Observation) -> None:
        if self.with_observations:
            self.record["initial_observations"] = _observations(obs)

    def step(self, actions, obs: Observation, rewards: np.ndarray, done: bool, info: dict) -> None:
        entry = {
            "actions": [int(a) for a in actions],
            "state": self.game.dump(),
            "rewards": [int(r) for r in rewards],
            "done": bool(done),
            "info": info,
        }
        if self.with_observations:
            entry["observations"] = _observations(obs)
        self.record["steps"].append(entry)

    def finish(self) -> dict:
        steps = self.record["steps"]
        self.record["num_steps"] = len(steps)
        self.record["final_info"] = steps[-1]["info"] if steps else info_dict(3, np.zeros(4))
        return self.record
