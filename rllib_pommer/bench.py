"""`python -m rllib_pommer.bench engine|agents|train|learn [--json]`: our speed, side by side.

`engine` runs protocol (a) of tests/reference/README.md §4 on the single-game API and on the
batched API: 200 Team games per run with precomputed uniform random actions (800 x 4 per game),
stepped until done; steps/s counts only time inside the step calls (which build all four
observations), games/s the whole reset + steps.

`agents` runs protocol (b): 20 games per run of four SimpleAgents, game g of run r seeded
2000 + 1000 r + g; steps/s and games/s over the whole loop including reset. It is measured twice:
with one `SimpleAgent` object per seat deciding per call (the reference's shape), and with the
batched kernel deciding for all 80 seats of the 20 games in one call per step.

`train` runs the quick curriculum's PPO config for a few iterations on the real env and on a
zero-cost env with the same spaces, in one run, and prints env steps/s for both and their ratio.

`learn` times the learners on one torch thread: the real RLlib PPO update (pi trainable, and pi
frozen as in the value warm-up) beside PPO's update in plain eager float32 NCHW torch (the
baseline), the real behaviour-cloning step beside its plain float32 NCHW form, and the float32
FLOP bound of this core (FLOPs per PPO sample counted by torch, peak measured on a matrix product).

Three runs each for engine and agents; min/median/max are printed. Pin the process to one core
(`taskset -c 0`) to compare per core with the reference.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from .agents.simple import SimpleAgent, new_memory, simple_actions
from .game.constants import TEAM
from .game.engine import Game, Games
from .game.state import A_ALIVE

GAMES_PER_RUN = 200
SIMPLE_GAMES_PER_RUN = 20
RUNS = 3
REPO_ROOT = Path(__file__).resolve().parents[1]
REFERENCE_SPEED = REPO_ROOT / "tests" / "reference" / "reference_speed.json"


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


def _simple_seeds(run: int) -> list[int]:
    return [2000 + 1000 * run + g for g in range(SIMPLE_GAMES_PER_RUN)]


def simple_objects_run(run: int) -> tuple[float, float]:
    """Protocol (b) with one SimpleAgent object per seat and the single-game API."""
    start = time.perf_counter()
    steps = 0
    for seed in _simple_seeds(run):
        game = Game(TEAM)
        obs = game.reset(seed)
        agents = [SimpleAgent() for _ in range(4)]
        for seat, agent in enumerate(agents):
            agent.reset(seat, int(TEAM.game_type), np.random.default_rng([seed, seat]))
        done = False
        while not done:
            alive = game.state.agents[0, :, A_ALIVE] != 0
            actions = [agents[s].act(obs.select(s)) if alive[s] else 0 for s in range(4)]
            obs, _, done, _ = game.step(actions)
            steps += 1
    total = time.perf_counter() - start
    return steps / total, SIMPLE_GAMES_PER_RUN / total


def simple_batched_run(run: int) -> tuple[float, float]:
    """Protocol (b) with the batched engine and one batched SimpleAgent call per step."""
    start = time.perf_counter()
    games = Games(SIMPLE_GAMES_PER_RUN, TEAM)
    games.reset(_simple_seeds(run))
    memory = new_memory(4 * SIMPLE_GAMES_PER_RUN, np.random.default_rng(run))
    steps = 0
    while not games.done.all():
        active = games.alive & ~games.done[:, None]
        actions = simple_actions(games.obs.agent_rows(), memory, active.ravel())
        steps += int((~games.done).sum())
        games.step(actions.reshape(-1, 4))
    total = time.perf_counter() - start
    return steps / total, SIMPLE_GAMES_PER_RUN / total


def _stats(values: list[float]) -> dict:
    return {"min": min(values), "median": statistics.median(values), "max": max(values),
            "runs": values}


def _measure(variants: dict, section: str, figure: str) -> dict:
    """Run each variant RUNS times after one warm-up run (compiles or loads the kernel cache).

    The result is flat: `<variant>_steps_per_s` and `<variant>_games_per_s` medians (min, median,
    max and runs under `..._runs`), the reference's median `reference_<figure>` from `section` of
    reference_speed.json, and `<variant>_ratio` = our median `figure` over the reference's.
    """
    for run in variants.values():
        run(0)
    out: dict = {}
    for name, run in variants.items():
        results = [run(r) for r in range(RUNS)]
        for i, unit in enumerate(("steps_per_s", "games_per_s")):
            stats = _stats([result[i] for result in results])
            out[f"{name}_{unit}"] = stats["median"]
            out[f"{name}_{unit}_runs"] = stats
    reference = json.loads(REFERENCE_SPEED.read_text())[section][figure]["median"]
    out[f"reference_{figure}"] = reference
    for name in variants:
        out[f"{name}_ratio"] = out[f"{name}_{figure}"] / reference
    return out


def bench_engine() -> dict:
    return _measure({"single": single_api_run, "batched": batched_api_run},
                    "a_random_env_step", "steps_per_s")


def bench_agents() -> dict:
    return _measure({"objects": simple_objects_run, "batched": simple_batched_run},
                    "b_simpleagent_games", "games_per_s")


def _print(title: str, result: dict) -> None:
    if not any(key.endswith("_runs") for key in result):
        print(title)
        for key, value in result.items():
            print(f"  {key:40s} {value}")
        return
    print(f"{title:44s} {'min':>10s} {'median':>10s} {'max':>10s}")
    for key, s in result.items():
        if key.endswith("_runs"):
            print(f"{key[:-5]:44s} {s['min']:10.1f} {s['median']:10.1f} {s['max']:10.1f}")
    print(", ".join(f"{k} {v:.1f}" for k, v in result.items() if k.startswith("reference")))
    print(", ".join(f"{k} {v:.1f}x" for k, v in result.items() if k.endswith("_ratio")))


def bench_train() -> dict:
    """PPO env steps/s on the real env and on a zero-cost env with the same spaces, one run."""
    from .rl.bench import bench_train as measure  # Ray and torch only for this target

    return measure()


def bench_learn() -> dict:
    """Learner samples/s: RLlib PPO and BC, each beside its plain-torch baseline, and the bound."""
    import torch

    from . import learn_speed  # torch only for this target
    from .rl.bench import bench_learner  # Ray only for this target

    torch.set_num_threads(1)
    torch.set_flush_denormal(True)
    result = {"torch_threads": 1, **bench_learner()}
    result["ppo_baseline_samples_per_s"] = learn_speed.plain_ppo_samples_per_s()
    result.update(learn_speed.bc_speeds())
    result.update(learn_speed.flop_bound())
    result["ppo_speedup"] = result["ppo_samples_per_s"] / result["ppo_baseline_samples_per_s"]
    result["bc_speedup"] = result["bc_samples_per_s"] / result["bc_baseline_samples_per_s"]
    return {k: round(v, 3) if isinstance(v, float) else v for k, v in result.items()}


TARGETS = {
    "engine": ("protocol (a): Team, 200 games x 3 runs", bench_engine),
    "agents": ("protocol (b): 4 SimpleAgents, 20 games x 3 runs", bench_agents),
    "train": ("PPO sampling + learning, real env vs zero-cost env", bench_train),
    "learn": ("learner samples/s, one torch thread, beside plain-torch baselines", bench_learn),
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.bench", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("target", choices=list(TARGETS), help="what to measure")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)
    if not REFERENCE_SPEED.exists():
        print(f"error: reference figures not found at {REFERENCE_SPEED}", file=sys.stderr)
        return 2
    title, measure = TARGETS[args.target]
    result = measure()
    if args.json:
        print(json.dumps(result))
    else:
        _print(title, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
