"""Work spread over processes as a stream: a bounded number of tasks in flight, results as they
finish. Submitting every task up front would hold all of them (and their futures) in memory
before the first one runs, which for a long match or dataset is gigabytes."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from itertools import islice
from typing import TypeVar

Item = TypeVar("Item")
Result = TypeVar("Result")


def map_unordered(fn: Callable[[Item], Result], items: Iterable[Item], workers: int,
                  initializer: Callable[[], None] | None = None,
                  in_flight: int | None = None) -> Iterator[tuple[Item, Result]]:
    """(item, fn(item)) for every item, in completion order, computed on `workers` processes
    (in this process if `workers` is 1) with at most `in_flight` (default 2 x workers) items
    submitted and not yet yielded."""
    items = iter(items)
    if workers <= 1:
        for item in items:
            yield item, fn(item)
        return
    limit = in_flight or 2 * workers
    with ProcessPoolExecutor(workers, initializer=initializer) as pool:
        pending = {pool.submit(fn, item): item for item in islice(items, limit)}
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                item = pending.pop(future)
                yield item, future.result()
            for item in islice(items, limit - len(pending)):
                pending[pool.submit(fn, item)] = item
