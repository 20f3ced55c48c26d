"""A recorded game as frames: what the board shows at each step, in full or as one agent sees it.

An agent's view comes from the record's observations when it has them, else from our engine's
observation of the recorded state (`Game.load`), so the fog rule lives in one place: the
observation kernel.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..game.constants import NUM_AGENTS
from ..game.engine import Game
from ..game.records import config_of, read_games
from ..game.serialize import load_state


@dataclass(frozen=True)
class Frame:
    """One picture: the board after `step` steps, in full (`viewer` None) or as `viewer` sees it."""

    step: int
    board: np.ndarray  # (S, S) item codes; Fog (5) outside the viewer's window
    bomb_life: np.ndarray  # (S, S) ticks left of the bomb on each visible cell, 0 where none
    agents: list[dict]  # the state's agent dicts (position, is_alive, ammo, ...)
    viewer: int | None = None
    words: list[list[int]] | None = None  # TeamRadio: each agent's last [word, word]


def load_game(path: str | Path, index: int = 0) -> dict:
    """Game `index` (from 0) of a .jsonl[.gz] file of game records, its every state checked as
    the engine checks a state it loads (board size, item codes, fields)."""
    count = 0
    for count, record in enumerate(read_games(path), 1):
        if count - 1 == index:
            for step, state in enumerate(game_states(record)):
                try:
                    load_state(state)
                except ValueError as exc:
                    raise ValueError(f"{path}: game {index}, step {step}: {exc}") from None
            return record
    raise ValueError(f"{path}: no game {index}; the file holds {count} game(s)")


def game_states(record: dict) -> list[dict]:
    """The initial state and the state after every step."""
    return [record["initial_state"]] + [step["state"] for step in record["steps"]]


def _bomb_life(state: dict) -> np.ndarray:
    size = len(state["board"])
    life = np.zeros((size, size), np.int64)
    for bomb in state["bombs"]:
        life[tuple(bomb["position"])] = bomb["life"]
    return life


def state_frame(state: dict) -> Frame:
    """The whole board of one state (the reference schema, e.g. `Game.dump()` of a live game)."""
    return Frame(state["step_count"], np.asarray(state["board"]), _bomb_life(state),
                 state["agents"], words=state.get("radio_from_agent"))


def _recorded_views(record: dict, viewer: int) -> list[tuple[np.ndarray, np.ndarray]] | None:
    if not record.get("has_observations") or "initial_observations" not in record:
        return None
    observations = [record["initial_observations"]] + [s["observations"] for s in record["steps"]]
    return [(np.asarray(o[viewer]["board"]), np.asarray(o[viewer]["bomb_life"]))
            for o in observations]


def _derived_views(record: dict, viewer: int) -> list[tuple[np.ndarray, np.ndarray]]:
    game = Game(config_of(record))
    views = []
    for state in game_states(record):
        obs = game.load(state)
        views.append((obs.board[viewer].astype(np.int64), obs.bomb_life[viewer].astype(np.int64)))
    return views


def frames(record: dict, viewer: int | None = None) -> list[Frame]:
    """Every frame of a game record, in full or through the fog of agent `viewer`."""
    states = game_states(record)
    if viewer is None:
        return [state_frame(s) for s in states]
    if not 0 <= viewer < NUM_AGENTS:
        raise ValueError(f"fog: agent {viewer} is not one of 0..{NUM_AGENTS - 1}")
    views = _recorded_views(record, viewer) or _derived_views(record, viewer)
    return [Frame(s["step_count"], board, life, s["agents"], viewer, s.get("radio_from_agent"))
            for s, (board, life) in zip(states, views, strict=True)]
