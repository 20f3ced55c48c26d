"""Fuzz the engine: millions of random steps over many boards, every step checked for invariants.

    python benchmarks/fuzz_engine.py [--steps 10000000] [--games 512] [--seed 0]

Team, FFA and TeamRadio each take a third of the steps, each in one batch of games (every third
slot gets a power start with kick and 3 ammo, so kicks and chains are common); finished games are
replaced by new boards. In TeamRadio every agent sends two random words a step, and after each
step the channel must hold them for the agents alive at its start and (0, 0) for the others
(docs/rules.md §10). Any violation is printed with the game seed and step and the run exits 1.
Not part of CI.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from numba import njit
from tqdm import tqdm

from rllib_pommer.game.constants import (
    FFA_PRESET,
    RADIO_NUM_WORDS,
    RADIO_PRESET,
    RADIO_VOCAB_SIZE,
    TEAM_PRESET,
)
from rllib_pommer.game.engine import Games
from rllib_pommer.game.invariants import VIOLATIONS, step_violation
from rllib_pommer.game.state import A_ALIVE, A_AMMO, A_KICK, M_BOMBS, M_DONE, M_ITEMS


@njit(cache=True)
def _check_batch(before_board, before_agents, before_bombs, before_items, before_meta, actions,
                 board, agents, bombs, flames, meta, capacity, was_done, codes):
    for n in range(board.shape[0]):
        if was_done[n]:
            codes[n] = 0
            continue
        codes[n] = step_violation(before_board[n], before_agents[n], before_bombs[n],
                                  before_meta[n, M_BOMBS], before_items[n],
                                  before_meta[n, M_ITEMS], actions[n], board[n], agents[n],
                                  bombs[n], flames[n], meta[n], capacity[n])


def fuzz(config, games: int, steps: int, rng: np.random.Generator, bar) -> tuple[int, list[str]]:
    batch = Games(games, config)
    seeds = rng.integers(0, 2**31, games)
    batch.reset(seeds)
    power = np.arange(games) % 3 == 0
    batch.state.agents[power, :, A_KICK] = 1
    batch.state.agents[power, :, A_AMMO] = 3
    capacity = batch.state.agents[:, :, A_AMMO].astype(np.int64)
    game_step = np.zeros(games, np.int64)
    codes = np.zeros(games, np.int64)
    done_steps, failures = 0, []
    while done_steps < steps and not failures:
        s = batch.state
        before = (s.board.copy(), s.agents.copy(), s.bombs.copy(), s.items.copy(), s.meta.copy())
        was_done = s.meta[:, M_DONE] != 0
        actions = rng.choice(6, size=(games, 4), p=[0.15, 0.15, 0.15, 0.15, 0.15, 0.25])
        if batch.radio:  # the words the channel must hold: (0, 0) from agents dead already
            words = rng.integers(0, RADIO_VOCAB_SIZE, (games, 4, RADIO_NUM_WORDS))
            sent = np.where(s.agents[:, :, A_ALIVE, None] != 0, words, 0)
            batch.step(np.concatenate([actions[..., None], words], axis=-1))
        else:
            batch.step(actions)
        _check_batch(*before, actions, s.board, s.agents, s.bombs, s.flames, s.meta, capacity,
                     was_done, codes)
        if batch.radio:
            wrong = ~was_done & (s.radio != sent).any(axis=(1, 2))
            for n in np.flatnonzero(wrong):
                failures.append(f"{config.name} seed {seeds[n]} step {game_step[n] + 1}: the "
                                f"channel holds {s.radio[n].tolist()}, sent {sent[n].tolist()}")
        live = int((~was_done).sum())
        done_steps += live
        game_step += ~was_done
        bar.update(live)
        for n in np.flatnonzero(codes):
            failures.append(f"{config.name} seed {seeds[n]} step {game_step[n]}: "
                            f"{VIOLATIONS[codes[n]]}")
        finished = np.flatnonzero(batch.done)
        if len(finished):
            seeds[finished] = rng.integers(0, 2**31, len(finished))
            batch.reset(seeds[finished], finished)
            batch.state.agents[finished[power[finished]], :, A_KICK] = 1
            batch.state.agents[finished[power[finished]], :, A_AMMO] = 3
            capacity[finished] = batch.state.agents[finished, :, A_AMMO]
            game_step[finished] = 0
    return done_steps, failures


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=10_000_000)
    parser.add_argument("--games", type=int, default=512)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    start = time.perf_counter()
    total, failures = 0, []
    with tqdm(total=args.steps, unit="step", unit_scale=True, mininterval=2) as bar:
        for config in (TEAM_PRESET, FFA_PRESET, RADIO_PRESET):
            steps, found = fuzz(config, args.games, args.steps // 3, rng, bar)
            total += steps
            failures += found
    for line in failures[:20]:
        print(line)
    print(f"fuzzed {total} steps in {time.perf_counter() - start:.0f} s, "
          f"{len(failures)} invariant failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
