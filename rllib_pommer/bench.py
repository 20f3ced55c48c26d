"""`python -m rllib_pommer.bench engine [--json]`: our speed beside the reference's figures.

`engine` runs protocol (a) of ../shared/reference/README.md §4 on the single-game API and on the
batched API: 200 Team games per run with precomputed uniform random actions (800 x 4 per game),
stepped until done; steps/s counts only time inside the step calls (which build all four
observations), games/s the whole reset + steps. Three runs; min/median/max are printed. Pin the
process to one core (`taskset -c 0`) to compare per core with the reference.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from .game.constants import TEAM
from .game.engine import Game, Games

GAMES_PER_RUN = 200
RUNS = 3
REPO_ROOT = Path(__file__).resolve().parents[1]
REFERENCE_SPEED = REPO_ROOT.parent / "shared" / "reference" / "reference_speed.json"


def _run_actions(run: int) -> tuple[np.ndarray, np.ndarray]:
    """Board seeds and an (games, 800, 4) action array for run `run`."""
    rng = np.random.default_rng(1000 + run)
    seeds = rng.integers(0, 2**31, GAMES_PER_RUN)
    return seeds, rng.integers(0, 6, (GAMES_PER_RUN, TEAM.max_steps, 4))


def single_api_run(run: int) -> tuple[float, float]:
    seeds, actions = _run_actions(run)
    game = Game(TEAM)
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
    games = Games(GAMES_PER_RUN, TEAM)
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


def _stats(values: list[float]) -> dict:
    return {"min": min(values), "median": statistics.median(values), "max": max(values),
            "runs": values}


def bench_engine() -> dict:
    single_api_run(0)  # compile (or load the compile cache) outside the timed runs
    batched_api_run(0)
    single = [single_api_run(r) for r in range(RUNS)]
    batched = [batched_api_run(r) for r in range(RUNS)]
    reference = json.loads(REFERENCE_SPEED.read_text())["a_random_env_step"]
    ref_steps = reference["steps_per_s"]["median"]
    out = {
        "single_steps_per_s": _stats([s for s, _ in single]),
        "single_games_per_s": _stats([g for _, g in single]),
        "batched_steps_per_s": _stats([s for s, _ in batched]),
        "batched_games_per_s": _stats([g for _, g in batched]),
        "reference_steps_per_s": ref_steps,
        "reference_games_per_s": reference["games_per_s"]["median"],
    }
    out["single_ratio"] = out["single_steps_per_s"]["median"] / ref_steps
    out["batched_ratio"] = out["batched_steps_per_s"]["median"] / ref_steps
    return out


def _print_engine(result: dict) -> None:
    title = "protocol (a), Team, 200 games x 3 runs"
    print(f"{title:44s} {'min':>10s} {'median':>10s} {'max':>10s}")
    for key in ("single_steps_per_s", "single_games_per_s", "batched_steps_per_s",
                "batched_games_per_s"):
        s = result[key]
        print(f"{key:44s} {s['min']:10.0f} {s['median']:10.0f} {s['max']:10.0f}")
    print(f"reference steps/s (median) {result['reference_steps_per_s']:.0f}, "
          f"games/s {result['reference_games_per_s']:.1f}")
    print(f"ratio single/reference {result['single_ratio']:.1f}x, "
          f"batched/reference {result['batched_ratio']:.1f}x")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.bench", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("target", choices=["engine"], help="what to measure")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)
    if not REFERENCE_SPEED.exists():
        print(f"error: reference figures not found at {REFERENCE_SPEED}", file=sys.stderr)
        return 2
    result = bench_engine()
    if args.json:
        print(json.dumps(result))
    else:
        _print_engine(result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
