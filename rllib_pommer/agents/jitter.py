"""The paper's Jitter Correction (Meisheri et al. 2019, Algorithm 1) over the agent's positions.

Policies imitated from SimpleAgent tend to freeze on one cell or to bounce between two cells when
nothing is in sight. The correction watches the agent's own position history and, on such a loop,
hands control to SimpleAgent (the "expert") for a few steps to break it.

Reading of Algorithm 1 (its pseudo-code has two slips, resolved by the intent its names state):

* stationary: the last 15 positions are one cell. (The printed test `len(xposition[-15:]) == 1`
  lacks the `set`; as printed it would only fire on the very first step.) Expert for 3 steps.
* for each axis (rows, then columns), oscillating: over the last 11 positions the coordinate at the
  odd offsets (-10, -8, ..., -2) is one value, at the even offsets (-11, -9, ..., -1) another one
  (the `odd`, `even` and `uneq` conditions together); or confined: over the last 35 positions the
  coordinate takes exactly two values while the other axis' coordinate is constant. (The printed
  `x_y_cond_long` repeats `xposition`; its name and "similar for y" say it is the other axis.)
  Expert for 2 steps.
* every window must be full: with a shorter history the slices would compare fewer positions and
  fire after one step of walking.

The trigger step itself is the first of the expert's steps, and conditions are not re-checked while
the expert drives; positions are recorded throughout, as Algorithm 1 appends every step. The
wrapped agent is asked on every step too, its answer discarded while the expert drives, so a
stateful policy sees an unbroken observation stream, as it does in RLlib, where the policy always
computes an action that post-processing may override. The expert is asked only when it drives (the
paper switches control), so its memory holds its own moves.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence

import numpy as np

from ..game.observation import Observation
from .base import Agent
from .simple import SimpleAgent

STATIONARY_WINDOW = 15
STATIONARY_EXPERT_STEPS = 3
OSCILLATION_WINDOW = 11
CONFINED_WINDOW = 35
OSCILLATION_EXPERT_STEPS = 2

Cell = tuple[int, int]


def _oscillating(coords: Sequence[int]) -> bool:
    if len(coords) < OSCILLATION_WINDOW:
        return False
    at_odd = set(coords[-OSCILLATION_WINDOW + 1 :: 2])
    at_even = set(coords[-OSCILLATION_WINDOW::2])
    return len(at_odd) == 1 and len(at_even) == 1 and at_odd != at_even


def _confined(coords: Sequence[int], other_coords: Sequence[int]) -> bool:
    if len(coords) < CONFINED_WINDOW:
        return False
    return (
        len(set(coords[-CONFINED_WINDOW:])) == 2 and len(set(other_coords[-CONFINED_WINDOW:])) == 1
    )


def expert_steps_for(history: Sequence[Cell]) -> int:
    """How many steps Algorithm 1 hands to the expert after `history` (oldest first); 0 if none."""
    if len(history) >= STATIONARY_WINDOW and len(set(history[-STATIONARY_WINDOW:])) == 1:
        return STATIONARY_EXPERT_STEPS
    rows = [cell[0] for cell in history]
    cols = [cell[1] for cell in history]
    for coords, other_coords in ((rows, cols), (cols, rows)):
        if _oscillating(coords) or _confined(coords, other_coords):
            return OSCILLATION_EXPERT_STEPS
    return 0


class JitterCorrection:
    """Wraps any agent; lets `expert` (a SimpleAgent by default) act when the agent loops."""

    def __init__(self, inner: Agent, expert: Agent | None = None):
        self.inner = inner
        self.expert = expert if expert is not None else SimpleAgent()
        # No condition looks further back than the longest window.
        self._history: deque[Cell] = deque(maxlen=CONFINED_WINDOW)
        self._expert_steps_left = 0

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        # The expert gets a spawned child stream, so the inner agent's stream is the one it would
        # see unwrapped.
        self.inner.reset(agent_id, game_type, rng)
        self.expert.reset(agent_id, game_type, rng.spawn(1)[0])
        self._history.clear()
        self._expert_steps_left = 0

    def act(self, obs: Observation) -> int:
        self._history.append((int(obs.position[0]), int(obs.position[1])))
        action = int(self.inner.act(obs))
        if self._expert_steps_left == 0:
            self._expert_steps_left = expert_steps_for(list(self._history))
        if self._expert_steps_left == 0:
            return action
        self._expert_steps_left -= 1
        return int(self.expert.act(obs))
