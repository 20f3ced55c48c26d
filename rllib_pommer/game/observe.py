"""Per-agent observations (docs/rules.md §5), compiled: fog window, masked bomb and flame maps."""

from __future__ import annotations

from numba import njit

from .constants import NUM_AGENTS, Item
from .state import (
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
    B_ROW,
    F_COL,
    F_LIFE,
    F_ROW,
    M_BOMBS,
    M_FLAMES,
    M_STEP,
)

FOG = int(Item.FOG)  # bound for the kernel (numba freezes globals)


@njit(cache=True, inline="always")
def _visible(r, c, cr, cc, view_radius):
    return view_radius < 0 or (abs(r - cr) <= view_radius and abs(c - cc) <= view_radius)


@njit(cache=True)
def observe_game(board, agents, bombs, flames, meta, view_radius, game_type,
                 o_board, o_blast, o_life, o_dir, o_flame, o_pos, o_ammo, o_strength, o_kick,
                 o_alive, o_type, o_step):
    """Write the four agents' observations of one game into the (4, ...) output slices.

    Dead agents are observed too, centred on their death cell, as in the reference. Fog hides
    board cells, bombs and flames outside the Chebyshev window (`view_radius` < 0: no fog).
    """
    size = board.shape[0]
    for a in range(NUM_AGENTS):
        cr, cc = agents[a, A_ROW], agents[a, A_COL]
        for r in range(size):
            for c in range(size):
                o_board[a, r, c] = board[r, c] if _visible(r, c, cr, cc, view_radius) else FOG
        o_blast[a] = 0
        o_life[a] = 0
        o_dir[a] = 0
        o_flame[a] = 0
        for b in range(meta[M_BOMBS]):
            r, c = bombs[b, B_ROW], bombs[b, B_COL]
            if _visible(r, c, cr, cc, view_radius):
                o_blast[a, r, c] = bombs[b, B_BLAST]
                o_life[a, r, c] = bombs[b, B_LIFE]
                o_dir[a, r, c] = bombs[b, B_DIR]
        for f in range(meta[M_FLAMES]):
            r, c = flames[f, F_ROW], flames[f, F_COL]
            if _visible(r, c, cr, cc, view_radius):
                o_flame[a, r, c] = flames[f, F_LIFE] + 1
        o_pos[a, 0], o_pos[a, 1] = cr, cc
        o_ammo[a] = agents[a, A_AMMO]
        o_strength[a] = agents[a, A_BLAST]
        o_kick[a] = agents[a, A_KICK] != 0
        for i in range(NUM_AGENTS):
            o_alive[a, i] = agents[i, A_ALIVE] != 0
        o_type[a] = game_type
        o_step[a] = meta[M_STEP]
