"""What the user-facing envs cost: import time of `rllib_pommer.envs` beside the RLlib env's, and
env steps/s of `rllib_pommer/PommeTeam-v0` with SimpleAgent on the three other seats.

Import times are wall times of fresh interpreters (`python -c "import X"`, the median of
`--repeats`), beside a bare interpreter's. Steps/s count `env.step` calls of `gymnasium.make`'s env
(its checker wrappers included), resets included, for two trained-seat policies: uniform random
actions (episodes end early, mostly by the agent's own bombs) and always Stop (longer episodes).

    python benchmarks/envs_speed.py [--steps 20000] [--repeats 5] [--json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time

import gymnasium as gym
import numpy as np

from rllib_pommer.envs import ENV_ID

IMPORTS = {"bare interpreter": "pass", "rllib_pommer.envs": "import rllib_pommer.envs",
           "rllib_pommer.rl.env (RLlib)": "import rllib_pommer.rl.env"}


def import_seconds(code: str, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def steps_per_second(steps: int, policy: str) -> tuple[float, float]:
    """(env steps/s, mean episode length) over `steps` steps from seed 0."""
    env = gym.make(ENV_ID)
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    env.step(0)  # compiled kernels loaded before timing
    env.reset(seed=0)
    episodes, start = 0, time.perf_counter()
    for _ in range(steps):
        action = int(rng.integers(6)) if policy == "random" else 0
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            episodes += 1
            env.reset()
    return steps / (time.perf_counter() - start), steps / max(episodes, 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if min(args.steps, args.repeats) < 1:
        parser.error("--steps and --repeats must be at least 1")
    result = {"import_seconds": {name: import_seconds(code, args.repeats)
                                 for name, code in IMPORTS.items()},
              "steps_per_second": {}}
    for policy in ("random", "stop"):
        rate, length = steps_per_second(args.steps, policy)
        result["steps_per_second"][policy] = {"steps_per_second": rate, "mean_episode": length}
    if args.json:
        print(json.dumps(result, indent=1))
        return
    for name, seconds in result["import_seconds"].items():
        print(f"import {name}: {seconds:.2f} s")
    for policy, row in result["steps_per_second"].items():
        print(f"{ENV_ID}, trained seat {policy}, SimpleAgent x3: "
              f"{row['steps_per_second']:.0f} env steps/s (episodes of {row['mean_episode']:.0f} "
              f"steps)")


if __name__ == "__main__":
    main()
