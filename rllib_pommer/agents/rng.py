"""Per-agent random streams that compiled kernels can carry in a plain array.

A numpy Generator is a Python object: it cannot be stored in an array, passed into a batched numba
kernel or advanced from inside one. So each agent row keeps its own stream as a single uint64
state, advanced with splitmix64 (Steele, Lea and Flood, "Fast splittable pseudorandom number
generators", OOPSLA 2014). One independent stream per agent also means an agent's choices depend
only on its own seed and observations, never on how games are batched or spread over processes.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_GOLDEN_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_S53 = np.uint64(53)
_INV_2_53 = 1.0 / 9007199254740992.0  # 2**-53


@njit(cache=True)
def next_u64(states: np.ndarray, i: int) -> np.uint64:
    """Advance stream `i` and return its next 64 random bits."""
    state = states[i] + _GOLDEN_GAMMA
    states[i] = state
    z = (state ^ (state >> _S30)) * _MIX1
    z = (z ^ (z >> _S27)) * _MIX2
    return z ^ (z >> _S31)


@njit(cache=True)
def next_uniform(states: np.ndarray, i: int) -> float:
    """A float in [0, 1) with 53 random bits."""
    return float(next_u64(states, i) >> _S11) * _INV_2_53


@njit(cache=True)
def next_below(states: np.ndarray, i: int, k: int) -> int:
    """An int in [0, k) for 1 <= k < 2**11: floor(u * k) computed exactly on 53-bit integers."""
    return int(((next_u64(states, i) >> _S11) * np.uint64(k)) >> _S53)


def seed_states(rng: np.random.Generator, m: int) -> np.ndarray:
    """`m` independent stream states drawn from `rng`."""
    return rng.integers(0, 2**64, size=m, dtype=np.uint64)
