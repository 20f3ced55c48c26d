"""How long an agent can stay alive: a scenario played forward by the compiled step, then the
cells an agent could occupy at each of its steps (docs/search.md §3).

`play_scenario` copies a believed state, takes the searching agent off the board (its own moves
are what the search varies, so the scenario does not depend on them), lets the agents in
`bombers` lay a bomb where they stand on the first step and all agents stand still after, and
records for every step which cells burn and which block a walker (walls, wood, bombs, agents).
`escape_cells` walks that record forward from a start cell: at each step the agent may stay or
step to a free neighbour, and dies on a burning cell; it returns how many cells it can be on at
the last step (0: no way to survive the scenario).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..game.constants import NUM_AGENTS, RADIO_NUM_WORDS, Action, Item
from ..game.state import A_ALIVE, A_COL, A_ROW
from ..game.step import step_game

PASSAGE, RIGID, WOOD, BOMB, FLAMES, AGENT0 = (
    int(i) for i in (Item.PASSAGE, Item.RIGID, Item.WOOD, Item.BOMB, Item.FLAMES, Item.AGENT0))
STOP, BOMB_ACTION = int(Action.STOP), int(Action.BOMB)
NEIGHBOURS = np.array([[-1, 0], [1, 0], [0, -1], [0, 1]], np.int64)
NO_CAP = 1 << 20


@njit(cache=True)
def play_scenario(board, agents, bombs, flames, items, meta, radio, me, bombers, fire, blocked):
    """Fill `fire` and `blocked` (H, S, S) bool for H = fire.shape[0] steps of the scenario of
    the module docstring; the state arrays are left unchanged."""
    size = board.shape[0]
    s_board, s_agents, s_bombs = board.copy(), agents.copy(), bombs.copy()
    s_flames, s_items, s_meta, s_radio = flames.copy(), items.copy(), meta.copy(), radio.copy()
    if s_agents[me, A_ALIVE] != 0:
        s_agents[me, A_ALIVE] = 0
        r, c = s_agents[me, A_ROW], s_agents[me, A_COL]
        if s_board[r, c] == AGENT0 + me:
            s_board[r, c] = PASSAGE  # a bomb under it is drawn again by the step
    actions = np.zeros(NUM_AGENTS, np.int64)
    words = np.zeros((NUM_AGENTS, RADIO_NUM_WORDS), np.int64)
    rewards = np.zeros(NUM_AGENTS, np.int64)
    burn = np.zeros((size, size), np.uint8)
    killers = np.zeros(NUM_AGENTS, np.uint8)
    for t in range(fire.shape[0]):
        for a in range(NUM_AGENTS):
            actions[a] = BOMB_ACTION if t == 0 and bombers[a] else STOP
        step_game(s_board, s_agents, s_bombs, s_flames, s_items, s_meta, s_radio, actions, words,
                  rewards, 2, 1 << 30, 4, burn, killers)
        for r in range(size):
            for c in range(size):
                code = s_board[r, c]
                fire[t, r, c] = code == FLAMES
                blocked[t, r, c] = code == RIGID or code == WOOD or code == BOMB or code >= AGENT0


@njit(cache=True)
def escape_cells(fire, blocked, row, col, cap=NO_CAP):
    """Cells an agent starting at (row, col) can be on after the last step of the record, alive
    at every step; counting stops at `cap`. Staying is always allowed (also on a bomb), a step
    only onto a neighbour that does not block; a burning cell kills."""
    steps, size = fire.shape[0], fire.shape[1]
    here = np.zeros((size, size), np.bool_)
    there = np.zeros((size, size), np.bool_)
    here[row, col] = True
    for t in range(steps):
        alive = False
        for r in range(size):
            for c in range(size):
                if fire[t, r, c]:
                    there[r, c] = False
                    continue
                ok = here[r, c]
                if not ok and not blocked[t, r, c]:
                    for k in range(4):
                        rr, cc = r + NEIGHBOURS[k, 0], c + NEIGHBOURS[k, 1]
                        if 0 <= rr < size and 0 <= cc < size and here[rr, cc]:
                            ok = True
                            break
                there[r, c] = ok
                alive = alive or ok
        if not alive:
            return 0
        here, there = there, here
    count = 0
    for r in range(size):
        for c in range(size):
            if here[r, c]:
                count += 1
                if count >= cap:
                    return count
    return count
