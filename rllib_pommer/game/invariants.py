"""Invariants every step must keep, checked from the states before and after it.

Compiled, so that the property tests and the 10-million-step fuzz script (benchmarks/) share one
check. The checks are deliberately independent of the step kernel's code paths: they re-derive
what must hold from the rules (docs/rules.md §3) rather than re-running the same logic.
"""

from __future__ import annotations

from numba import njit

from .constants import (
    FLAME_LIFE_AT_CREATION,
    NUM_AGENTS,
    STATE_BOARD_CODES,
    Action,
    Item,
)
from .state import (
    A_ALIVE,
    A_AMMO,
    A_BLAST,
    A_COL,
    A_ROW,
    B_BLAST,
    B_COL,
    B_OWNER,
    B_ROW,
    F_COL,
    F_LIFE,
    F_ROW,
    I_CODE,
    I_COL,
    I_ROW,
    M_BOMBS,
    M_FLAMES,
)

VIOLATIONS = (
    "ok",
    "board holds a code that a true board never holds",
    "two living agents share a cell",
    "a living agent is not drawn on its cell, or a dead one is drawn",
    "an agent's ammo plus its live bombs exceed its capacity",
    "a flame has a life outside 0..2 or its cell does not show Flames",
    "a new flame lies outside every blast cross of this step's bombs",
)
# Bound for the kernels (numba freezes module globals).
EXTRA_BOMB, FLAMES, AGENT0 = int(Item.EXTRA_BOMB), int(Item.FLAMES), int(Item.AGENT0)
BOMB_ACTION = int(Action.BOMB)


@njit(cache=True)
def _in_reach(r, c, br, bc, reach):
    return (br == r and abs(bc - c) <= reach) or (bc == c and abs(br - r) <= reach)


@njit(cache=True)
def _new_flame_explained(r, c, before_bombs, n_before, before_agents, actions):
    """Some bomb of this step (old, possibly moved one cell, or laid now) reaches (r, c)."""
    for b in range(n_before):
        reach = before_bombs[b, B_BLAST] - 1
        for dr, dc in ((0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)):
            if _in_reach(r, c, before_bombs[b, B_ROW] + dr, before_bombs[b, B_COL] + dc, reach):
                return True
    for a in range(NUM_AGENTS):
        if before_agents[a, A_ALIVE] != 0 and actions[a] == BOMB_ACTION:
            reach = before_agents[a, A_BLAST] - 1
            if _in_reach(r, c, before_agents[a, A_ROW], before_agents[a, A_COL], reach):
                return True
    return False


@njit(cache=True)
def _extra_bomb_under(r, c, before_board, before_items, n_before_items):
    """Whether an agent arriving at (r, c) this step could pick up an ExtraBomb there: shown on
    the board, or hidden under a flame that expires at the start of this step."""
    if before_board[r, c] == EXTRA_BOMB:
        return True
    if before_board[r, c] != FLAMES:
        return False
    for i in range(n_before_items):
        if before_items[i, I_ROW] == r and before_items[i, I_COL] == c:
            return before_items[i, I_CODE] == EXTRA_BOMB
    return False


@njit(cache=True)
def step_violation(before_board, before_agents, before_bombs, n_before, before_items,
                   n_before_items, actions, board, agents, bombs, flames, meta, capacity):
    """Index into VIOLATIONS of the first broken invariant (0 if none); updates `capacity`.

    `capacity[a]` is the agent's bomb capacity (starting ammo plus ExtraBombs picked up); the
    caller initialises it from the starting ammo.
    """
    size = board.shape[0]
    for r in range(size):
        for c in range(size):
            valid = False
            for code in STATE_BOARD_CODES:
                if board[r, c] == code:
                    valid = True
            if not valid:
                return 1
    for a in range(NUM_AGENTS):
        moved = (agents[a, A_ROW] != before_agents[a, A_ROW]
                 or agents[a, A_COL] != before_agents[a, A_COL])
        if moved and _extra_bomb_under(agents[a, A_ROW], agents[a, A_COL], before_board,
                                       before_items, n_before_items):
            capacity[a] += 1
        if agents[a, A_ALIVE] == 0:
            continue
        for other in range(a + 1, NUM_AGENTS):
            if (agents[other, A_ALIVE] != 0 and agents[other, A_ROW] == agents[a, A_ROW]
                    and agents[other, A_COL] == agents[a, A_COL]):
                return 2
    for a in range(NUM_AGENTS):
        drawn = 0
        for r in range(size):
            for c in range(size):
                if board[r, c] == AGENT0 + a:
                    drawn += 1
        if agents[a, A_ALIVE] != 0:
            if drawn != 1 or board[agents[a, A_ROW], agents[a, A_COL]] != AGENT0 + a:
                return 3
        elif drawn != 0:
            return 3
    for a in range(NUM_AGENTS):
        live = 0
        for b in range(meta[M_BOMBS]):
            if bombs[b, B_OWNER] == a:
                live += 1
        if agents[a, A_AMMO] + live > capacity[a]:
            return 4
    for f in range(meta[M_FLAMES]):
        r, c, life = flames[f, F_ROW], flames[f, F_COL], flames[f, F_LIFE]
        if life < 0 or life > FLAME_LIFE_AT_CREATION or board[r, c] != FLAMES:
            return 5
        if life == FLAME_LIFE_AT_CREATION and not _new_flame_explained(
                r, c, before_bombs, n_before, before_agents, actions):
            return 6
    return 0
