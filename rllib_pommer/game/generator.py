"""Board generation with the reference's distribution and invariants (docs/rules.md §2).

Randomness comes from a numpy Generator only.

The reference picks mirror pairs of cells one at a time; a uniform pick among the remaining pairs
is the same as a uniform permutation of all pairs, so the 18 rigid and 12 wood pairs are the first
30 entries of one permutation. The board is rejected when more than 4 Passage cells cannot be
reached from (9, 9). The 20 hidden power-ups sit on distinct wood cells chosen uniformly, each of a
uniform type. The reference's random stream is not reproduced, only its distribution.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .constants import (
    BOARD_SIZE,
    DEFAULT_AMMO,
    DEFAULT_BLAST_STRENGTH,
    NUM_AGENTS,
    START_POSITIONS,
    GameConfig,
    Item,
)
from .state import A_ALIVE, A_AMMO, A_BLAST, A_COL, A_ROW, M_ITEMS, GameState

MAX_UNREACHABLE_PASSAGES = 4
PASSAGE, RIGID = int(Item.PASSAGE), int(Item.RIGID)  # bound for the kernel below


def _layout(size: int) -> tuple[np.ndarray, list[tuple[int, int]], np.ndarray]:
    """The fixed skeleton (agents, guaranteed wood) and the candidate mirror pairs."""
    skeleton = np.zeros((size, size), np.uint8)
    for agent, (r, c) in enumerate(START_POSITIONS):
        skeleton[r, c] = Item.AGENT0 + agent
    reserved = {(r, c) for r, c in START_POSITIONS}
    last = size - 1
    for k in (2, 3):
        reserved |= {(1, k), (k, 1), (last - 1, last - k), (last - k, last - 1),
                     (1, last - k), (last - k, 1), (k, last - 1), (last - 1, k)}
    for i in (4, 5, 6):
        for r, c in ((1, i), (last - i, 1), (last - 1, last - i), (last - i, last - 1)):
            skeleton[r, c] = Item.WOOD
            reserved.add((r, c))
    pairs = [(r, c) for r in range(size) for c in range(r + 1, size)
             if (r, c) not in reserved and (c, r) not in reserved]
    return skeleton, pairs, np.array(pairs, np.int64)


_SKELETON, _PAIR_LIST, _PAIRS = _layout(BOARD_SIZE)


def fixed_cells() -> np.ndarray:
    """(S, S) int8: the code every starting board holds on each cell (docs/rules.md §2.2), or -1
    where walls are drawn at random. The agents' corners read Passage (agents move off them), so
    an agent can tell these cells without seeing them."""
    fixed = np.where(_SKELETON >= Item.AGENT0, Item.PASSAGE, _SKELETON).astype(np.int8)
    fixed[_PAIRS[:, 0], _PAIRS[:, 1]] = -1
    fixed[_PAIRS[:, 1], _PAIRS[:, 0]] = -1
    return fixed


@njit(cache=True)
def count_unreachable_passages(board, start_row, start_col):
    """Passage cells that a 4-way flood fill from the start (through all but Rigid) misses."""
    size = board.shape[0]
    seen = np.zeros((size, size), np.bool_)
    queue = np.empty((size * size, 2), np.int64)
    queue[0, 0], queue[0, 1] = start_row, start_col
    seen[start_row, start_col] = True
    head, tail = 0, 1
    while head < tail:
        r, c = queue[head, 0], queue[head, 1]
        head += 1
        for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
            rr, cc = r + dr, c + dc
            if 0 <= rr < size and 0 <= cc < size and not seen[rr, cc] and board[rr, cc] != RIGID:
                seen[rr, cc] = True
                queue[tail, 0], queue[tail, 1] = rr, cc
                tail += 1
    missed = 0
    for r in range(size):
        for c in range(size):
            if board[r, c] == PASSAGE and not seen[r, c]:
                missed += 1
    return missed


def generate_board(
    rng: np.random.Generator, config: GameConfig
) -> tuple[np.ndarray, np.ndarray]:
    """A new board and its hidden items (rows [row, col, code] in placement order)."""
    if config.board_size != BOARD_SIZE or config.num_rigid != 36 or config.num_wood != 36:
        raise ValueError(f"board generation supports the {BOARD_SIZE}x{BOARD_SIZE} presets only, "
                         f"not {config.name!r}")
    n_rigid_pairs = config.num_rigid // 2
    n_wood_pairs = (config.num_wood - 12) // 2
    while True:
        board = _SKELETON.copy()
        order = rng.permutation(len(_PAIRS))
        rigid = _PAIRS[order[:n_rigid_pairs]]
        wood = _PAIRS[order[n_rigid_pairs : n_rigid_pairs + n_wood_pairs]]
        board[rigid[:, 0], rigid[:, 1]] = Item.RIGID
        board[rigid[:, 1], rigid[:, 0]] = Item.RIGID
        board[wood[:, 0], wood[:, 1]] = Item.WOOD
        board[wood[:, 1], wood[:, 0]] = Item.WOOD
        last = START_POSITIONS[2]
        if count_unreachable_passages(board, *last) <= MAX_UNREACHABLE_PASSAGES:
            break
    wood_cells = np.argwhere(board == Item.WOOD)
    chosen = wood_cells[rng.choice(len(wood_cells), config.num_items, replace=False)]
    codes = rng.integers(Item.EXTRA_BOMB, Item.KICK + 1, config.num_items)
    return board, np.column_stack([chosen, codes]).astype(np.int32)


def reset_game(state: GameState, index: int, rng: np.random.Generator, config: GameConfig) -> None:
    """Put a freshly generated game into slot `index` of `state`."""
    board, items = generate_board(rng, config)
    for arr in state:
        arr[index] = 0
    state.board[index] = board
    state.items[index, : len(items)] = items
    state.meta[index, M_ITEMS] = len(items)
    for agent in range(NUM_AGENTS):
        row = state.agents[index, agent]
        row[A_ROW], row[A_COL] = START_POSITIONS[agent]
        row[A_ALIVE] = 1
        row[A_AMMO] = DEFAULT_AMMO
        row[A_BLAST] = DEFAULT_BLAST_STRENGTH
