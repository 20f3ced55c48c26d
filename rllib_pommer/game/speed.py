"""How fast the engine steps, for `bench engine`: protocol (a) of docs/measurements.md.

One run plays `GAMES_PER_RUN` Team games with precomputed uniform random actions (max_steps x 4
per game, seeded by the run number) until done, on the single-game API or on the batched one.
steps/s counts only the time inside the step calls (which build all four observations); games/s
the whole reset plus steps. Each run returns (steps/s, games/s).
"""

from __future__ import annotations

import time

import numpy as np

from .constants import NUM_ACTIONS, NUM_AGENTS, TEAM_PRESET
from .engine import Game, Games

GAMES_PER_RUN = 200


def _run_actions(run: int) -> tuple[np.ndarray, np.ndarray]:
    """Board seeds and a (games, max_steps, 4) action array for run `run`."""
    rng = np.random.default_rng(1000 + run)
    seeds = rng.integers(0, 2**31, GAMES_PER_RUN)
    return seeds, rng.integers(0, NUM_ACTIONS, (GAMES_PER_RUN, TEAM_PRESET.max_steps, NUM_AGENTS))


def single_api_run(run: int) -> tuple[float, float]:
    seeds, actions = _run_actions(run)
    game = Game(TEAM_PRESET)
    steps, in_step = 0, 0.0
    start = time.perf_counter()
    for g in range(GAMES_PER_RUN):
        game.reset(int(seeds[g]))
        done, k = False, 0
        while not done:
            t0 = time.perf_counter()
            done = game.step(actions[g, k])[2]
            in_step += time.perf_counter() - t0
            k += 1
        steps += k
    total = time.perf_counter() - start
    return steps / in_step, GAMES_PER_RUN / total


def batched_api_run(run: int) -> tuple[float, float]:
    seeds, actions = _run_actions(run)
    start = time.perf_counter()
    games = Games(GAMES_PER_RUN, TEAM_PRESET)
    games.reset(seeds)
    steps, in_step, k = 0, 0.0, 0
    while not games.done.all():
        steps += int((~games.done).sum())
        t0 = time.perf_counter()
        games.step(actions[:, k])
        in_step += time.perf_counter() - t0
        k += 1
    total = time.perf_counter() - start
    return steps / in_step, GAMES_PER_RUN / total
