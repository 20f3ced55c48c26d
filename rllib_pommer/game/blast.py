"""The blast cross of one bomb, shared by the step kernel and by agents that predict explosions."""

from __future__ import annotations

from numba import njit

from .constants import Item

RIGID, WOOD = int(Item.RIGID), int(Item.WOOD)  # bound for the kernels (numba freezes globals)


@njit(cache=True, inline="always")
def _mark_ray(board, mask, r, c, dr, dc, first, last):
    size = board.shape[0]
    for k in range(first, last):
        rr = r + dr * k
        cc = c + dc * k
        if rr < 0 or rr >= size or cc < 0 or cc >= size:
            return
        cell = board[rr, cc]
        if cell == RIGID:
            return
        mask[rr, cc] = 1
        if cell == WOOD:
            return


@njit(cache=True)
def mark_blast(board, mask, r, c, strength):
    """Set `mask` on every cell the bomb at (r, c) with `strength` sets on fire.

    Reach is strength - 1 cells per ray. The reference's "down" ray starts at distance 0, so it is
    the one that marks the bomb's own cell (docs/rules.md §3.12). Rigid stops a ray unmarked; Wood
    is marked and stops it; nothing else stops it.
    """
    _mark_ray(board, mask, r, c, -1, 0, 1, strength)
    _mark_ray(board, mask, r, c, 1, 0, 0, strength)
    _mark_ray(board, mask, r, c, 0, -1, 1, strength)
    _mark_ray(board, mask, r, c, 0, 1, 1, strength)
