"""Where our agents stand and where they lay bombs, from replays, for the paper's Fig. 5.

Every seat is mirrored so that it starts top-left like agent 0 (agent 1 starts bottom-left, 2
bottom-right, 3 top-right). A bomb placement is a bomb of that bomber with life 9 in a state: bombs
are laid with life 10 and tick in the same step, so only a bomb laid on that step shows 9.

Whose agents are "ours", which policy they play and who the opponent is come from the replay's
keys `seats_a`, `team` (with `filters`) and `vs` when present. Otherwise `agent_mix` is read as
the arena writes it (four policy names by seat) with the arena's seat rule (team A on {0, 2} in
even games, {1, 3} in odd ones); without a `game` key, team A is taken to sit on {0, 2}.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from ..game.constants import BOARD_SIZE, BOMB_LIFE_AT_LAYING, START_POSITIONS

FRESH_BOMB_LIFE = BOMB_LIFE_AT_LAYING - 1
GAMES_PER_OPPONENT = 50


def _board_counts() -> np.ndarray:
    return np.zeros((BOARD_SIZE, BOARD_SIZE), np.int64)


@dataclass
class Heatmaps:
    """Counts over the games of one opponent, in top-left coordinates."""

    positions: np.ndarray = field(default_factory=_board_counts)
    bombs: np.ndarray = field(default_factory=_board_counts)
    games: int = 0


def to_top_left(position, seat: int, size: int = BOARD_SIZE) -> tuple[int, int]:
    """A seat's (row, col) mirrored so that the seat's start maps to agent 0's start."""
    r, c = position
    start_r, start_c = START_POSITIONS[seat]
    home_r, home_c = START_POSITIONS[0]
    return (r if start_r == home_r else size - 1 - r, c if start_c == home_c else size - 1 - c)


def seats_and_opponent(record: dict) -> tuple[tuple[int, ...], str]:
    """Team A's seats and team B's name in a replay (see the module docstring)."""
    names = str(record.get("agent_mix", "")).split()
    if "seats_a" in record:
        seats = tuple(record["seats_a"])
    else:
        seats = (1, 3) if record.get("game", 0) % 2 else (0, 2)
    if "vs" in record:
        return seats, str(record["vs"])
    other = next(s for s in range(4) if s not in seats)
    return seats, names[other] if len(names) == 4 else str(record.get("agent_mix", "?"))


def team_name(record: dict, seats: tuple[int, ...]) -> str:
    """Team A's policy in a replay, with its filters as the arena names them (`ppo+jitter`)."""
    if "team" in record:
        return "+".join([str(record["team"]), *record.get("filters", [])])
    names = str(record.get("agent_mix", "")).split()
    return names[seats[0]] if len(names) == 4 else "?"


def add_game(maps: Heatmaps, record: dict, seats: Iterable[int]) -> None:
    """Count the positions of `seats` in every state and their freshly laid bombs."""
    seats = tuple(seats)
    states = [record["initial_state"]] + [step["state"] for step in record["steps"]]
    for state in states:
        for seat in seats:
            agent = state["agents"][seat]
            if agent["is_alive"]:
                maps.positions[to_top_left(agent["position"], seat)] += 1
        for bomb in state["bombs"]:
            if bomb["bomber_id"] in seats and bomb["life"] == FRESH_BOMB_LIFE:
                maps.bombs[to_top_left(bomb["position"], bomb["bomber_id"])] += 1
    maps.games += 1


def heatmaps_by_opponent(records: Iterable[dict], games_per_opponent: int = GAMES_PER_OPPONENT
                         ) -> dict[tuple[str, str], Heatmaps]:
    """Heatmaps of team A by (team A's policy, opponent), over the first `games_per_opponent`
    games of each pair."""
    by_match: dict[tuple[str, str], Heatmaps] = {}
    for record in records:
        seats, opponent = seats_and_opponent(record)
        maps = by_match.setdefault((team_name(record, seats), opponent), Heatmaps())
        if maps.games < games_per_opponent:
            add_game(maps, record, seats)
    return by_match
