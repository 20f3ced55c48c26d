"""What a searching agent believes the game state is: its observation, filled in under the fog
from what it saw before (docs/search.md §1).

The belief is built from the agent's own observations alone. Memory keeps, per cell, the last
code seen there and when, the bomb and flame seen on it, and the step at which the agent's own
bomb there was laid; per agent, where it was last seen and the largest blast it was seen to lay.
From these `rebuild` writes a full game state (`game/state.GameState`'s arrays for one game)
that the compiled step can advance: cells in view as observed, fogged cells as last seen with
their bombs and flames aged by the steps since, never-seen cells from the board's mirror
symmetry (docs/rules.md §2.3) or else as wood, and the other agents where they were last seen,
if that was recently enough and their cell is out of view.

Memory is one flat int64 row per agent so that it can ride in RLlib's episode state; an all-zero
row is a fresh memory (its first `remember` fills in the start of a game: every agent in its
corner, docs/rules.md §2.1).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..game.constants import (
    BOARD_SIZE,
    DEFAULT_BLAST_STRENGTH,
    MAX_BOMBS,
    MAX_FLAMES,
    MAX_ITEMS,
    NUM_AGENTS,
    RADIO_NUM_WORDS,
    START_POSITIONS,
    Action,
    Item,
)
from ..game.generator import fixed_cells
from ..game.state import (
    A_ALIVE,
    A_AMMO,
    A_BLAST,
    A_COL,
    A_KICK,
    A_ROW,
    B_BLAST,
    B_COL,
    B_DIR,
    B_LIFE,
    B_OWNER,
    B_ROW,
    F_COL,
    F_LIFE,
    F_ROW,
    M_BOMBS,
    M_FLAMES,
    M_STEP,
)

CELLS = BOARD_SIZE * BOARD_SIZE
# Per-cell planes of the memory row, each CELLS long, at offset plane * CELLS.
P_CODE, P_SEEN, P_LIFE, P_BLAST, P_DIR, P_FLAME, P_MINE = range(7)
AGENT_BASE = 7 * CELLS
# Per-agent fields, 4 each, at AGENT_BASE + 4 * agent.
G_ROW, G_COL, G_SEEN, G_BLAST = range(4)
LAST_ACTION = AGENT_BASE + 4 * NUM_AGENTS  # the move this row answered last
STARTED = LAST_ACTION + 1  # 0 in a fresh row
RNG = STARTED + 1  # the row's splitmix64 stream state, as int64 bits
MEMORY_SIZE = RNG + 1

LIFE_AT_SIGHT = 9  # a bomb is first seen with life 9 (docs/rules.md §8 item 5)
PASSAGE, RIGID, WOOD, BOMB, FLAMES, FOG = (
    int(i) for i in (Item.PASSAGE, Item.RIGID, Item.WOOD, Item.BOMB, Item.FLAMES, Item.FOG))
EXTRA_BOMB, KICK, AGENT0 = int(Item.EXTRA_BOMB), int(Item.KICK), int(Item.AGENT0)
BOMB_ACTION = int(Action.BOMB)
STARTS = np.array(START_POSITIONS, np.int64)
FIXED = fixed_cells()


def new_memory(rows: int) -> np.ndarray:
    """Fresh (all-zero) memory rows."""
    return np.zeros((rows, MEMORY_SIZE), np.int64)


@njit(cache=True, inline="always")
def _start(memory):
    for p in range(CELLS):
        memory[P_CODE * CELLS + p] = FOG
        memory[P_SEEN * CELLS + p] = -1
        memory[P_MINE * CELLS + p] = -1
    for a in range(NUM_AGENTS):
        base = AGENT_BASE + 4 * a
        memory[base + G_ROW] = STARTS[a, 0]
        memory[base + G_COL] = STARTS[a, 1]
        memory[base + G_SEEN] = 0
        memory[base + G_BLAST] = DEFAULT_BLAST_STRENGTH
    memory[STARTED] = 1


@njit(cache=True)
def remember(board, blast, life, direction, flame, position, me, step, memory):
    """Fold one observation into `memory` (one row, updated in place)."""
    if memory[STARTED] == 0:
        _start(memory)
    size = board.shape[0]
    mr, mc = position[0], position[1]
    if memory[LAST_ACTION] == BOMB_ACTION and life[mr, mc] == LIFE_AT_SIGHT:
        memory[P_MINE * CELLS + mr * size + mc] = step
    for r in range(size):
        for c in range(size):
            code = board[r, c]
            if code == FOG:
                continue
            p = r * size + c
            if code >= AGENT0:
                agent = code - AGENT0
                base = AGENT_BASE + 4 * agent
                memory[base + G_ROW] = r
                memory[base + G_COL] = c
                memory[base + G_SEEN] = step
                if life[r, c] == LIFE_AT_SIGHT and agent != me:
                    memory[base + G_BLAST] = max(memory[base + G_BLAST], blast[r, c])
            memory[P_CODE * CELLS + p] = PASSAGE if code >= AGENT0 or code == BOMB else code
            memory[P_SEEN * CELLS + p] = step
            memory[P_LIFE * CELLS + p] = life[r, c]
            memory[P_BLAST * CELLS + p] = blast[r, c]
            memory[P_DIR * CELLS + p] = direction[r, c]
            memory[P_FLAME * CELLS + p] = flame[r, c]


@njit(cache=True, inline="always")
def _unseen_code(memory, r, c, size):
    """A never-seen cell: what every board holds there at the start, if that is fixed; else
    rigid if its mirror image was seen rigid (walls are drawn in mirror pairs); else wood, the
    cautious guess (it blocks a path and stops a blast)."""
    if FIXED[r, c] >= 0:
        return FIXED[r, c]
    return RIGID if memory[P_CODE * CELLS + c * size + r] == RIGID else WOOD


@njit(cache=True)
def rebuild(board, blast, life, direction, flame, position, ammo, strength, can_kick, alive, me,
            step, recall, memory, s_board, s_agents, s_bombs, s_flames, s_meta):
    """Write the believed state of one game into the `s_` arrays (one game, no batch axis).

    Agents other than `me` are placed where seen now, or where last seen if that was at most
    `recall` steps ago, their cell is out of view and free; others count as absent (not alive)
    in the belief. Believed agents hold one bomb and the largest blast they were seen to lay,
    and cannot kick. A bomb's owner is `me` if `me` laid a bomb there whose life matches, else
    the next seat (an enemy in Team games: only ammo refunds depend on it).
    """
    size = board.shape[0]
    n_bombs = 0
    n_flames = 0
    other = (me + 1) % NUM_AGENTS
    for r in range(size):
        for c in range(size):
            p = r * size + c
            code = board[r, c]
            b_life, b_blast, b_dir, f_life = life[r, c], blast[r, c], direction[r, c], flame[r, c]
            if code == FOG:
                code = memory[P_CODE * CELLS + p]
                age = step - memory[P_SEEN * CELLS + p]
                b_life = max(memory[P_LIFE * CELLS + p] - age, 0)
                b_blast = memory[P_BLAST * CELLS + p]
                b_dir = memory[P_DIR * CELLS + p]
                f_life = max(memory[P_FLAME * CELLS + p] - age, 0)
                if code == FOG:
                    code = _unseen_code(memory, r, c, size)
                elif code == FLAMES and f_life == 0:
                    code = PASSAGE
                if b_dir != 0:  # a rolling bomb out of view could be anywhere now
                    b_life = 0
                if b_life > 0:
                    code = BOMB
            s_board[r, c] = code
            if b_life > 0:
                mine = memory[P_MINE * CELLS + p]
                owner = me if mine >= 0 and step - mine == LIFE_AT_SIGHT - b_life else other
                s_bombs[n_bombs, B_ROW] = r
                s_bombs[n_bombs, B_COL] = c
                s_bombs[n_bombs, B_OWNER] = owner
                s_bombs[n_bombs, B_LIFE] = b_life
                s_bombs[n_bombs, B_BLAST] = b_blast
                s_bombs[n_bombs, B_DIR] = b_dir
                n_bombs += 1
            if f_life > 0:
                s_flames[n_flames, F_ROW] = r
                s_flames[n_flames, F_COL] = c
                s_flames[n_flames, F_LIFE] = f_life - 1
                n_flames += 1
    for a in range(NUM_AGENTS):
        base = AGENT_BASE + 4 * a
        r, c = memory[base + G_ROW], memory[base + G_COL]
        s_agents[a, A_ROW], s_agents[a, A_COL] = r, c
        s_agents[a, A_ALIVE] = 0
        s_agents[a, A_AMMO] = 1
        s_agents[a, A_BLAST] = memory[base + G_BLAST]
        s_agents[a, A_KICK] = 0
        if a == me:
            s_agents[a, A_ROW], s_agents[a, A_COL] = position[0], position[1]
            s_agents[a, A_ALIVE] = alive[a]
            s_agents[a, A_AMMO], s_agents[a, A_BLAST] = ammo, strength
            s_agents[a, A_KICK] = can_kick
            continue
        if not alive[a]:
            continue
        if memory[base + G_SEEN] == step and board[r, c] == AGENT0 + a:
            s_agents[a, A_ALIVE] = 1
            continue
        here = s_board[r, c]
        free = here == PASSAGE or here == BOMB or EXTRA_BOMB <= here <= KICK
        if board[r, c] == FOG and step - memory[base + G_SEEN] <= recall and free:
            s_agents[a, A_ALIVE] = 1
            s_board[r, c] = AGENT0 + a
    s_meta[:] = 0
    s_meta[M_STEP] = step
    s_meta[M_BOMBS] = n_bombs
    s_meta[M_FLAMES] = n_flames


def empty_belief() -> tuple:
    """The arrays `rebuild` fills and the step kernel advances, for one game:
    board, agents, bombs, flames, items, meta, radio (`game/state.GameState` without the batch
    axis)."""
    return (np.zeros((BOARD_SIZE, BOARD_SIZE), np.uint8), np.zeros((NUM_AGENTS, 6), np.int32),
            np.zeros((MAX_BOMBS, 6), np.int32), np.zeros((MAX_FLAMES, 3), np.int32),
            np.zeros((MAX_ITEMS, 3), np.int32), np.zeros(5, np.int32),
            np.zeros((NUM_AGENTS, RADIO_NUM_WORDS), np.uint8))
