"""Streaming work over processes: every item once, a bounded number in flight."""

from __future__ import annotations

import itertools

import pytest

from rllib_pommer.util.parallel import map_unordered


def _square(x: int) -> int:
    return x * x


@pytest.mark.parametrize("workers", [1, 2])
def test_every_item_once_with_its_result(workers):
    pairs = list(map_unordered(_square, range(20), workers))
    assert sorted(pairs) == [(x, x * x) for x in range(20)]


def test_items_are_drawn_lazily():
    """An endless source is fine: only what is in flight has been taken from it."""
    drawn = itertools.count()
    results = map_unordered(_square, drawn, workers=2, in_flight=3)
    first = [next(results) for _ in range(5)]
    assert len(first) == 5
    assert next(drawn) <= 5 + 3  # at most the yielded ones plus those in flight were drawn
    results.close()
