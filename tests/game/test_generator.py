"""Board generation keeps the reference invariants (docs/rules.md §2) for every seed."""

from __future__ import annotations

import numpy as np
import pytest

from rllib_pommer.game.constants import START_POSITIONS, TEAM_PRESET, Item
from rllib_pommer.game.generator import count_unreachable_passages, generate_board

FIXED_WOOD = {(1, 4), (1, 5), (1, 6), (4, 1), (5, 1), (6, 1),
              (9, 4), (9, 5), (9, 6), (4, 9), (5, 9), (6, 9)}
BREATHING_ROOM = {(1, 2), (1, 3), (2, 1), (3, 1), (1, 7), (1, 8), (7, 1), (8, 1),
                  (2, 9), (3, 9), (9, 2), (9, 3), (7, 9), (8, 9), (9, 7), (9, 8)}
SEEDS = range(400)


@pytest.fixture(scope="module")
def boards():
    return [generate_board(np.random.default_rng(seed), TEAM_PRESET) for seed in SEEDS]


def test_wall_counts_and_symmetry(boards):
    for board, _ in boards:
        assert (board == Item.RIGID).sum() == 36
        assert (board == Item.WOOD).sum() == 36
        walls = np.where(np.isin(board, [Item.RIGID, Item.WOOD]), board, 0)
        assert np.array_equal(walls, walls.T)
        assert set(np.unique(board)) <= {0, 1, 2, 10, 11, 12, 13}


def test_fixed_skeleton(boards):
    for board, _ in boards:
        for agent, (r, c) in enumerate(START_POSITIONS):
            assert board[r, c] == Item.AGENT0 + agent
        assert all(board[cell] == Item.WOOD for cell in FIXED_WOOD)
        assert all(board[cell] == Item.PASSAGE for cell in BREATHING_ROOM)
        diagonal = [board[i, i] for i in range(11) if i not in (1, 9)]
        assert diagonal == [Item.PASSAGE] * 9


def test_connectivity_check_holds(boards):
    for board, _ in boards:
        assert count_unreachable_passages(board, 9, 9) <= 4


def test_items_sit_on_distinct_wood_cells(boards):
    for board, items in boards:
        assert len(items) == 20
        cells = {(int(r), int(c)) for r, c, _ in items}
        assert len(cells) == 20
        assert all(board[r, c] == Item.WOOD for r, c in cells)
        assert set(items[:, 2].tolist()) <= {6, 7, 8}


def test_item_types_and_wood_cells_are_uniform(boards):
    codes = np.concatenate([items[:, 2] for _, items in boards])
    shares = np.bincount(codes, minlength=9)[6:] / len(codes)
    assert np.all(np.abs(shares - 1 / 3) < 0.03), shares
    fixed_hits = sum((int(r), int(c)) in FIXED_WOOD for _, items in boards for r, c, _ in items)
    # 12 of 36 wood cells are fixed; each item cell is a uniform pick among the 36.
    assert abs(fixed_hits / (20 * len(boards)) - 12 / 36) < 0.03


def test_same_seed_same_board_and_different_seeds_differ():
    a = generate_board(np.random.default_rng(5), TEAM_PRESET)
    b = generate_board(np.random.default_rng(5), TEAM_PRESET)
    c = generate_board(np.random.default_rng(6), TEAM_PRESET)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert not np.array_equal(a[0], c[0])


def test_flood_fill_counts_walled_off_passages():
    board = np.zeros((11, 11), np.uint8)
    board[0:3, 3] = Item.RIGID
    board[3, 0:3] = Item.RIGID
    assert count_unreachable_passages(board, 9, 9) == 9
    board[3, 1] = Item.WOOD  # wood is traversable for the check
    assert count_unreachable_passages(board, 9, 9) == 0
