"""How long an agent can stay alive: a scenario played forward by the compiled step, then the
cells an agent could occupy at each of its steps (docs/search.md §3).

`play_scenario` copies a believed state, takes the searching agent off the board (its own moves
are what the search varies, so the scenario does not depend on them), lets the agents in
`bombers` lay a bomb where they stand on the first step and all agents stand still after (a
bomber's body is also assumed on any free cell it could have walked to, up to a few steps), and
records for every step which cells burn and which block a walker (walls, wood, bombs, agents).
`escape_cells` walks that record forward from a start cell: at each step the agent may stay or
step to a free neighbour, and dies on a burning cell; it returns how many cells it can be on at
the last step (0: no way to survive the scenario).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..game.constants import BOMB_LIFE_AT_LAYING, NUM_AGENTS, Action, Item
from ..game.state import (
    A_ALIVE,
    A_AMMO,
    A_BLAST,
    A_COL,
    A_ROW,
    B_BLAST,
    B_COL,
    B_DIR,
    B_LIFE,
    B_OWNER,
    B_ROW,
    M_BOMBS,
)
from ..game.step import step_buffers, step_game

PASSAGE, RIGID, WOOD, BOMB, FLAMES, AGENT0 = (
    int(i) for i in (Item.PASSAGE, Item.RIGID, Item.WOOD, Item.BOMB, Item.FLAMES, Item.AGENT0))
EXTRA_BOMB, KICK = int(Item.EXTRA_BOMB), int(Item.KICK)
STOP, BOMB_ACTION = int(Action.STOP), int(Action.BOMB)
NEIGHBOURS = np.array([[-1, 0], [1, 0], [0, -1], [0, 1]], np.int64)
NO_CAP = 1 << 20


@njit(cache=True)
def _walk_steps(board, row, col, limit, out):
    """`out` (S, S): the fewest steps from (row, col) to each cell over free cells (Passage,
    power-ups) within `limit` steps, else a number above `limit`."""
    size = board.shape[0]
    out[:] = limit + 1
    out[row, col] = 0
    queue = np.empty((size * size, 2), np.int64)
    queue[0, 0], queue[0, 1] = row, col
    head, tail = 0, 1
    while head < tail:
        r, c = queue[head, 0], queue[head, 1]
        head += 1
        if out[r, c] >= limit:
            continue
        for k in range(4):
            rr, cc = r + NEIGHBOURS[k, 0], c + NEIGHBOURS[k, 1]
            if not (0 <= rr < size and 0 <= cc < size) or out[rr, cc] <= limit:
                continue
            code = board[rr, cc]
            if code == PASSAGE or EXTRA_BOMB <= code <= KICK:
                out[rr, cc] = out[r, c] + 1
                queue[tail, 0], queue[tail, 1] = rr, cc
                tail += 1


@njit(cache=True)
def play_scenario(board, agents, bombs, flames, items, meta, radio, me, bombers, walk, head_start,
                  fire, blocked):
    """Fill `fire` and `blocked` (H, S, S) bool for H = fire.shape[0] steps of the scenario of
    the module docstring; the state arrays are left unchanged. Each bomber may also stand on any
    free cell within `walk` steps of it that it can have reached by then, having had
    `head_start` steps before the scenario began: those cells block too."""
    size = board.shape[0]
    near = np.zeros((size, size), np.int64)
    ghost = np.full((size, size), 1 << 20, np.int64)  # from which step a bomber may stand there
    for a in range(NUM_AGENTS):
        if bombers[a] and agents[a, A_ALIVE] != 0 and walk > 0:
            _walk_steps(board, agents[a, A_ROW], agents[a, A_COL], walk, near)
            for r in range(size):
                for c in range(size):
                    if near[r, c] <= walk:
                        ghost[r, c] = min(ghost[r, c], near[r, c])
    s_board, s_agents, s_bombs = board.copy(), agents.copy(), bombs.copy()
    s_flames, s_items, s_meta, s_radio = flames.copy(), items.copy(), meta.copy(), radio.copy()
    if s_agents[me, A_ALIVE] != 0:
        s_agents[me, A_ALIVE] = 0
        r, c = s_agents[me, A_ROW], s_agents[me, A_COL]
        if s_board[r, c] == AGENT0 + me:
            s_board[r, c] = PASSAGE  # a bomb under it is drawn again by the step
    actions = np.zeros(NUM_AGENTS, np.int64)
    words, rewards, burn, killers, laid = step_buffers(size)
    for t in range(fire.shape[0]):
        for a in range(NUM_AGENTS):
            actions[a] = BOMB_ACTION if t == 0 and bombers[a] else STOP
        step_game(s_board, s_agents, s_bombs, s_flames, s_items, s_meta, s_radio, actions, words,
                  rewards, 2, 1 << 30, 4, burn, killers, laid)
        for r in range(size):
            for c in range(size):
                code = s_board[r, c]
                fire[t, r, c] = code == FLAMES
                blocked[t, r, c] = (code == RIGID or code == WOOD or code == BOMB
                                    or code >= AGENT0 or ghost[r, c] <= t + head_start)


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


@njit(cache=True)
def rooms_under_threat(board, agents, bombs, flames, items, meta, radio, horizon, cap,
                       lay=True):
    """(4,) int64: for each living agent of a Team game, the cells it can be on after `horizon`
    steps of the scenario in which both enemies (the seats of the other parity) lay a bomb
    where they stand now (`lay`; else nobody does) and everybody then stands still, counted up
    to `cap`; 0: an enemy bomb laid now would trap it (without `lay`: it is trapped already).
    A dead agent's entry is 0. Team rewards read it as how cornered each agent stands
    (game/rewards.py, "raw_kills_room")."""
    size = board.shape[0]
    fire = np.zeros((horizon, size, size), np.bool_)
    blocked = np.zeros((horizon, size, size), np.bool_)
    bombers = np.zeros(NUM_AGENTS, np.bool_)
    rooms = np.zeros(NUM_AGENTS, np.int64)
    for me in range(NUM_AGENTS):
        if agents[me, A_ALIVE] == 0:
            continue
        for a in range(NUM_AGENTS):
            bombers[a] = lay and a % 2 != me % 2 and agents[a, A_ALIVE] != 0
        play_scenario(board, agents, bombs, flames, items, meta, radio, me, bombers, 0, 0, fire,
                      blocked)
        rooms[me] = escape_cells(fire, blocked, agents[me, A_ROW], agents[me, A_COL], cap)
    return rooms


@njit(cache=True)
def escapes_if_bombing(board, agents, bombs, flames, items, meta, radio, bomber, horizon):
    """(4,) int64: whether each living agent has a way to survive `horizon` steps if `bomber`
    lays a bomb where it stands now and nobody lays another (1 yes, 0 no; -1 dead), the bomber
    included. All -1 if the bomber cannot lay one now (dead, no ammo, a bomb on its cell).
    The bomb is added to the state as laid this step, then `rooms_under_threat` plays it out
    with no other bomb laid."""
    out = np.full(NUM_AGENTS, -1, np.int64)
    row, col = agents[bomber, A_ROW], agents[bomber, A_COL]
    count = meta[M_BOMBS]
    if agents[bomber, A_ALIVE] == 0 or agents[bomber, A_AMMO] <= 0 or count >= bombs.shape[0]:
        return out
    for b in range(count):
        if bombs[b, B_ROW] == row and bombs[b, B_COL] == col:
            return out
    laid, laid_meta = bombs.copy(), meta.copy()
    laid[count, B_ROW], laid[count, B_COL], laid[count, B_OWNER] = row, col, bomber
    laid[count, B_LIFE], laid[count, B_BLAST], laid[count, B_DIR] = (
        BOMB_LIFE_AT_LAYING, agents[bomber, A_BLAST], 0)
    laid_meta[M_BOMBS] = count + 1
    escapes = rooms_under_threat(board, agents, laid, flames, items, laid_meta, radio, horizon,
                                 1, False)
    for a in range(NUM_AGENTS):
        out[a] = escapes[a] if agents[a, A_ALIVE] != 0 else -1
    return out
