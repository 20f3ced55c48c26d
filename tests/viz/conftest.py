"""Small recorded games for the picture tests, played here with our engine (no reference data)."""

from __future__ import annotations

import numpy as np
import pytest

from rllib_pommer.game.constants import TEAM_PRESET
from rllib_pommer.game.engine import Game
from rllib_pommer.game.records import GameRecorder, write_games

# Bomb-happy random play: games end within a few dozen steps, with bombs, flames and deaths.
ACTION_WEIGHTS = np.array([1, 2, 2, 2, 2, 3]) / 12


def play_recorded(seed: int, max_steps: int = 120, with_observations: bool = False,
                  **extra) -> dict:
    """One Team game of biased random play as a game record (plus `extra` top-level keys)."""
    rng = np.random.default_rng(seed)
    game = Game(TEAM_PRESET)
    game.reset(seed)
    recorder = GameRecorder(game.batch, 0, seed, "RRRR", with_observations)
    recorder.start()
    for _ in range(max_steps):
        actions = rng.choice(6, size=4, p=ACTION_WEIGHTS)
        done = game.step(actions)[2]
        recorder.step(actions)
        if done:
            break
    return {**recorder.finish(), **extra}


@pytest.fixture(scope="session")
def game_record() -> dict:
    """A game with at least one death, recorded without observations."""
    for seed in range(100):
        record = play_recorded(seed)
        if not all(a["is_alive"] for a in record["steps"][-1]["state"]["agents"]):
            return record
    raise AssertionError("no death in 100 random games")


@pytest.fixture(scope="session")
def replay_file(tmp_path_factory, game_record):
    path = tmp_path_factory.mktemp("replays") / "games.jsonl.gz"
    write_games(path, [game_record, play_recorded(7, with_observations=True)])
    return path
