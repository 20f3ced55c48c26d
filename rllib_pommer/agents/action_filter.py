"""The paper's Action Filter (Meisheri et al. 2019, Algorithm 2): veto actions that end in flames.

From one agent's own observation we can tell exactly which visible cells will hold flames at the
end of the coming step (docs/rules.md §3.1, §3.11-3.13):

* a flame observed with flame_life >= 2 survives the flame-ageing sub-step; one observed with
  flame_life 1 is removed at the start of the step, so its cell is safe to enter;
* a bomb observed with bomb_life 1 explodes during the step, and so does every bomb that lies in
  its blast cross or on a surviving flame (chain explosions, iterated to a fixed point).

Rays are traced with the engine's own `mark_blast` on the observed board. That board is exact for
blast purposes: agents, bombs, power-ups and flames never stop a ray, and walls only burn at the
end of the step. Bomb positions come from the bomb maps, because an agent standing on its bomb
hides it on the board. A moving bomb may or may not advance this step (another agent or bomb can
block it), so both its current and its next cell count as its possible blast centre. Fog is read as
open ground, so a hidden wall never shortens a predicted ray.

The filter judges an action by the cell the agent ends the step on: Stop and Bomb keep the current
cell; a move onto an off-board, Rigid or Wood cell leaves the agent where it is; a move onto a cell
held by a bomb or another agent may bounce (docs/rules.md §3.4-3.7), so both cells must be safe;
any other move ends on the target cell. Movement contests with other agents are not predicted:
they depend on the other agents' actions, which are unknown.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..game.blast import mark_blast
from ..game.constants import ACTION_DC, ACTION_DR, NUM_ACTIONS, Action, Item
from ..game.observation import Observation
from .base import Agent

# Replacement candidates: the paper never substitutes a Bomb for a vetoed action.
MOVEMENT_ACTIONS = (Action.STOP, Action.UP, Action.DOWN, Action.LEFT, Action.RIGHT)


@njit(cache=True, inline="always")
def _bomb_may_enter(board, r, c):
    """Whether a moving bomb could advance onto (r, c) (docs/rules.md §3.3); Fog counts as open."""
    size = board.shape[0]
    if r < 0 or r >= size or c < 0 or c >= size:
        return False
    cell = board[r, c]
    return not (cell == Item.RIGID or cell == Item.WOOD or Item.EXTRA_BOMB <= cell <= Item.KICK)


@njit(cache=True)
def predict_flames(board, bomb_life, bomb_blast_strength, bomb_moving_direction, flame_life):
    """Mask (uint8, S x S) of the visible cells that hold flames at the end of the coming step."""
    flames = (flame_life >= 2).astype(np.uint8)
    rows, cols = np.nonzero(bomb_life)
    num_bombs = rows.shape[0]
    # Each bomb's possible centres after the move sub-step: its cell, plus the next one if moving.
    centres = np.empty((num_bombs, 2, 2), np.int64)
    num_centres = np.ones(num_bombs, np.int64)
    for b in range(num_bombs):
        r, c = rows[b], cols[b]
        centres[b, 0, 0], centres[b, 0, 1] = r, c
        direction = bomb_moving_direction[r, c]
        if 1 <= direction <= 4:
            nr, nc = r + ACTION_DR[direction], c + ACTION_DC[direction]
            if _bomb_may_enter(board, nr, nc):
                centres[b, 1, 0], centres[b, 1, 1] = nr, nc
                num_centres[b] = 2
    exploded = np.zeros(num_bombs, np.bool_)
    changed = True
    while changed:
        changed = False
        for b in range(num_bombs):
            if exploded[b]:
                continue
            goes_off = bomb_life[rows[b], cols[b]] == 1
            for k in range(num_centres[b]):
                goes_off = goes_off or flames[centres[b, k, 0], centres[b, k, 1]] != 0
            if goes_off:
                exploded[b] = True
                changed = True
                strength = bomb_blast_strength[rows[b], cols[b]]
                for k in range(num_centres[b]):
                    mark_blast(board, flames, centres[b, k, 0], centres[b, k, 1], strength)
    return flames


@njit(cache=True)
def _safe_action_mask(board, bomb_life, deadly, r, c):
    size = board.shape[0]
    stay_safe = not deadly[r, c]
    safe = np.empty(NUM_ACTIONS, np.bool_)
    for action in range(NUM_ACTIONS):
        tr, tc = r + ACTION_DR[action], c + ACTION_DC[action]
        if (tr == r and tc == c) or tr < 0 or tr >= size or tc < 0 or tc >= size:
            safe[action] = stay_safe
            continue
        target = board[tr, tc]
        if target == Item.RIGID or target == Item.WOOD:
            safe[action] = stay_safe
        elif bomb_life[tr, tc] > 0 or target >= Item.AGENT0:
            safe[action] = stay_safe and not deadly[tr, tc]
        else:
            safe[action] = not deadly[tr, tc]
    return safe


def deadly_cells(obs: Observation) -> np.ndarray:
    """Bool mask (S x S) of the cells on fire after the coming step, as far as `obs` shows."""
    flames = predict_flames(
        obs.board, obs.bomb_life, obs.bomb_blast_strength, obs.bomb_moving_direction, obs.flame_life
    )
    return flames.view(np.bool_)


def safe_actions(obs: Observation) -> np.ndarray:
    """Bool mask (6,) of the actions after which the agent does not end the step in flames."""
    row, col = int(obs.position[0]), int(obs.position[1])
    return _safe_action_mask(obs.board, obs.bomb_life, deadly_cells(obs), row, col)


class ActionFilter:
    """Wraps any agent; replaces its action when `safe_actions` says that action is deadly.

    The replacement is drawn uniformly from the safe movement actions other than the vetoed one.
    That is what the paper's loop ("take any random action ... until a safe one is found") yields,
    drawn in one go. When no such action is safe the agent is lost whatever it does (or the danger
    comes from something the observation cannot show), so the inner agent's own action is kept:
    the filter then changes nothing rather than picking an arbitrary move.
    """

    def __init__(self, inner: Agent):
        self.inner = inner
        self._rng: np.random.Generator | None = None

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        # A spawned child leaves `rng` untouched, so the inner agent sees the same stream as it
        # would unwrapped, and the filter's draws never shift the inner agent's.
        self._rng = rng.spawn(1)[0]
        self.inner.reset(agent_id, game_type, rng)

    def act(self, obs: Observation) -> int:
        action = int(self.inner.act(obs))
        safe = safe_actions(obs)
        if safe[action]:
            return action
        replacements = [int(a) for a in MOVEMENT_ACTIONS if a != action and safe[a]]
        if not replacements:
            return action
        return replacements[self._rng.integers(len(replacements))]
