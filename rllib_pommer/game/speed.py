"""How fast the engine steps, for `bench engine`: protocol (a) of docs/measurements.md.

One run plays `GAMES_PER_RUN` games of a preset with precomputed uniform random actions (max_steps
x 4 per game, seeded by the run number) until done, on the single-game API or on the batched one.
In TeamRadio every action also carries two uniform random words, drawn after the moves, so a radio
run plays the very games of the Team run with the same number: the difference is the radio
channel's cost. steps/s counts only the time inside the step calls (which build all four
observations); games/s the whole reset plus steps. Each run returns (steps/s, games/s).
"""

from __future__ import annotations

import time

import numpy as np

from .constants import (
    NUM_ACTIONS,
    NUM_AGENTS,
    RADIO_NUM_WORDS,
    RADIO_VOCAB_SIZE,
    TEAM_PRESET,
    GameConfig,
    has_radio,
)
from .engine import Game, Games

GAMES_PER_RUN = 200


def _run_actions(run: int, config: GameConfig) -> tuple[np.ndarray, np.ndarray]:
    """Board seeds and a (games, max_steps, 4) action array for run `run`, (games, max_steps,
    4, 3) [move, word, word] in TeamRadio."""
    rng = np.random.default_rng(1000 + run)
    seeds = rng.integers(0, 2**31, GAMES_PER_RUN)
    shape = (GAMES_PER_RUN, config.max_steps, NUM_AGENTS)
    moves = rng.integers(0, NUM_ACTIONS, shape)
    if not has_radio(config.game_type):
        return seeds, moves
    words = rng.integers(0, RADIO_VOCAB_SIZE, shape + (RADIO_NUM_WORDS,))
    return seeds, np.concatenate([moves[..., None], words], axis=-1)


def single_api_run(run: int, config: GameConfig = TEAM_PRESET) -> tuple[float, float]:
    seeds, actions = _run_actions(run, config)
    game = Game(config)
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


def batched_api_run(run: int, config: GameConfig = TEAM_PRESET) -> tuple[float, float]:
    seeds, actions = _run_actions(run, config)
    start = time.perf_counter()
    games = Games(GAMES_PER_RUN, config)
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
