"""A rate's 95% interval: one rule for the arena's summary and the report's tables.

Wilson's score interval (the reference statistics use it too): unlike the normal approximation it
stays inside [0, 1] and is not empty at 0 or n successes. Clamped, since the closed form can cross
0 or 1 by a rounding error (a tie rate of 0 would read [-0.000, 0.161]).
"""

from __future__ import annotations

import math


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95% Wilson score interval of `successes` out of `n` (all of [0, 1] when n is 0)."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))
