"""The game state: a few fixed-shape arrays with a leading batch axis.

A batch of N games is one `GameState`; a single game is a batch of one. Variable-length lists of the
reference (bombs, flames, hidden items) are stored as fixed-capacity tables plus a count in `meta`,
in the reference's list order, because that order decides collisions and is part of the recorded
state. Keeping everything in plain integer arrays is what lets the compiled step kernel run without
any Python object per cell or per step.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .constants import BOARD_SIZE, MAX_BOMBS, MAX_FLAMES, MAX_ITEMS, NUM_AGENTS, RADIO_NUM_WORDS

# Columns of `GameState.agents` (N, 4, 6).
A_ROW, A_COL, A_ALIVE, A_AMMO, A_BLAST, A_KICK = range(6)
# Columns of `GameState.bombs` (N, MAX_BOMBS, 6); `B_DIR` is 0 when the bomb is not moving.
B_ROW, B_COL, B_OWNER, B_LIFE, B_BLAST, B_DIR = range(6)
# Columns of `GameState.flames` (N, MAX_FLAMES, 3).
F_ROW, F_COL, F_LIFE = range(3)
# Columns of `GameState.items` (N, MAX_ITEMS, 3): hidden power-ups in insertion order.
I_ROW, I_COL, I_CODE = range(3)
# Columns of `GameState.meta` (N, 5).
M_STEP, M_ITEMS, M_BOMBS, M_FLAMES, M_DONE = range(5)


class GameState(NamedTuple):
    """Full state of N games.

    board:  (N, S, S) uint8 item codes, exactly the reference's internal board.
    agents: (N, 4, 6) int32 rows [row, col, alive, ammo, blast_strength, can_kick] by agent id.
    bombs:  (N, MAX_BOMBS, 6) int32 rows [row, col, owner, life, blast_strength, direction].
    flames: (N, MAX_FLAMES, 3) int32 rows [row, col, life].
    items:  (N, MAX_ITEMS, 3) int32 rows [row, col, item code] of hidden power-ups.
    meta:   (N, 5) int32 [step_count, n_items, n_bombs, n_flames, done].
    radio:  (N, 4, 2) uint8 the words each agent sent in the last step, by agent id (TeamRadio,
            docs/rules.md §10; all zero in the other games).
    """

    board: np.ndarray
    agents: np.ndarray
    bombs: np.ndarray
    flames: np.ndarray
    items: np.ndarray
    meta: np.ndarray
    radio: np.ndarray

    @property
    def num_games(self) -> int:
        return self.board.shape[0]

    @property
    def board_size(self) -> int:
        return self.board.shape[1]

    def copy(self) -> GameState:
        return GameState(*(a.copy() for a in self))

    def game(self, n: int) -> GameState:
        """Game `n` as a batch of one (a copy)."""
        return GameState(*(a[n : n + 1].copy() for a in self))


def empty_state(num_games: int, board_size: int = BOARD_SIZE) -> GameState:
    """Zeroed state arrays for `num_games` games."""
    return GameState(
        board=np.zeros((num_games, board_size, board_size), np.uint8),
        agents=np.zeros((num_games, NUM_AGENTS, 6), np.int32),
        bombs=np.zeros((num_games, MAX_BOMBS, 6), np.int32),
        flames=np.zeros((num_games, MAX_FLAMES, 3), np.int32),
        items=np.zeros((num_games, MAX_ITEMS, 3), np.int32),
        meta=np.zeros((num_games, 5), np.int32),
        radio=np.zeros((num_games, NUM_AGENTS, RADIO_NUM_WORDS), np.uint8),
    )
