"""`python -m rllib_pommer.bench engine|agents|search|train|scale|learn [--json]`: our speed,
side by side.

Each target's measures live beside the code they measure; this job runs them, and for engine and
agents compares with the reference's figures (tests/reference/reference_speed.json):

- `engine`: protocol (a) of docs/measurements.md (speed protocols) on the single-game and the
  batched API (`game/speed.py`), for Team and, on the same games, TeamRadio with words (the
  `radio_..._vs_team` figures are radio's median over Team's);
- `agents`: protocol (b), four SimpleAgents as one object per seat and as the batched kernel
  (`agents/speed.py`);
- `search`: the search agent's time per decision (p50, p99, max over 100 games against
  SimpleAgent, after one warm-up game), at its default effort (`search`) and the cheaper one
  (`search_fast`), and the arena's games/s on one worker (`agents/speed.py`, `arena/match.py`);
- `train`: the quick curriculum's PPO for a few iterations on the real env and on a zero-cost twin
  with the same spaces; env steps/s of both and their ratio (`launch/speed.py`);
- `scale`: the league curriculum's PPO on the real env for every layout a 2-core machine allows
  (env runners 0/1/2; the learner in the algorithm's process on 1 or 2 threads, or 1 or 2 learner
  actors): whole-loop env steps/s, sampling's env steps/s and the learner's samples/s alone,
  memory, ratios to the default layout, and projections to 8, 32 and 128 cores
  (`launch/scale.py`; meaningful on an otherwise idle machine);
- `learn`: on a run's torch threads (one), the real RLlib PPO update (pi trainable, and frozen as
  in the value warm-up) and the real behaviour-cloning step, each beside its plain float32 NCHW
  torch baseline, this core's float32 FLOP bound, and the learner connector's seconds on one
  iteration with and without its trained-agents-only head (`launch/speed.py`, `imitation/speed.py`).

Three runs each for engine and agents; min/median/max are printed. Pin the process to one core
(`taskset -c 0`) to compare per core with the reference.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from functools import partial
from pathlib import Path

from .util.errors import report_error

RUNS = 3
REPO_ROOT = Path(__file__).resolve().parents[1]
REFERENCE_SPEED = REPO_ROOT / "tests" / "reference" / "reference_speed.json"


def _stats(values: list[float]) -> dict:
    return {"min": min(values), "median": statistics.median(values), "max": max(values),
            "runs": values}


def _measure(variants: dict, section: str, figure: str) -> dict:
    """Run each variant RUNS times after one warm-up run (compiles or loads the kernel cache),
    the variants taking turns run by run so that a change of load hits them alike.

    The result is flat: `<variant>_steps_per_s` and `<variant>_games_per_s` medians (min, median,
    max and runs under `..._runs`), the reference's median `reference_<figure>` from `section` of
    reference_speed.json, and `<variant>_ratio` = our median `figure` over the reference's.
    """
    for run in variants.values():
        run(0)
    out: dict = {}
    runs = {name: [] for name in variants}
    for r in range(RUNS):
        for name, run in variants.items():
            runs[name].append(run(r))
    for name, results in runs.items():
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
    from .game.constants import RADIO_PRESET
    from .game.speed import batched_api_run, single_api_run

    apis = {"single": single_api_run, "batched": batched_api_run}
    variants = {**apis, **{f"radio_{api}": partial(run, config=RADIO_PRESET)
                           for api, run in apis.items()}}
    out = _measure(variants, "a_random_env_step", "steps_per_s")
    for api in apis:
        out[f"radio_{api}_vs_team"] = out[f"radio_{api}_steps_per_s"] / out[f"{api}_steps_per_s"]
    return out


def bench_agents() -> dict:
    from .agents.speed import simple_batched_run, simple_objects_run

    return _measure({"objects": simple_objects_run, "batched": simple_batched_run},
                    "b_simpleagent_games", "games_per_s")


SEARCH_POLICIES = ("search", "search_fast")
ARENA_GAMES = 32


def bench_search() -> dict:
    """Per search policy: its decision times against SimpleAgent and arena games/s (one worker,
    seed 0)."""
    from .agents import speed
    from .arena.match import MatchSpec, play_match

    out = {}
    for policy in SEARCH_POLICIES:
        speed.decision_times(policy, "simple", 1)  # compiles, or loads the kernel cache
        times = speed.decision_times(policy, "simple", speed.SEARCH_GAMES)
        out.update({f"{policy}_{k}": v for k, v in times.items()})
        start = time.perf_counter()
        play_match(MatchSpec(policy, "simple", ARENA_GAMES), workers=1)
        out[f"{policy}_arena_games_per_s"] = ARENA_GAMES / (time.perf_counter() - start)
    return out


def bench_train() -> dict:
    """PPO env steps/s on the real env and on a zero-cost env with the same spaces, one run."""
    from .launch.speed import train_speeds  # Ray and torch only for this target

    return train_speeds()


def bench_scale() -> dict:
    """The league curriculum's loop, phases and memory for every 2-core layout, one run."""
    from .launch.scale import scale_speeds  # Ray and torch only for this target

    return scale_speeds()


def bench_learn() -> dict:
    """Learner samples/s: RLlib PPO and BC, each beside its plain-torch baseline, and the bound."""
    from .launch.speed import learner_speeds  # Ray and torch only for this target

    return learner_speeds()


def _print(title: str, result: dict) -> None:
    if "layouts" in result:  # bench scale
        from .launch.scale import scale_table

        print(title)
        print(scale_table(result))
        print(f"best: {result['best']} ({result['best_command']})")
        return
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
    if any(k.endswith("_vs_team") for k in result):
        print(", ".join(f"{k} {v:.3f}" for k, v in result.items() if k.endswith("_vs_team")))


TARGETS = {
    "engine": ("protocol (a): Team and TeamRadio, 200 games x 3 runs", bench_engine),
    "agents": ("protocol (b): 4 SimpleAgents, 20 games x 3 runs", bench_agents),
    "search": ("search agent: ms per decision vs SimpleAgent (100 games), arena games/s",
               bench_search),
    "train": ("PPO sampling + learning, real env vs zero-cost env", bench_train),
    "scale": ("PPO on every layout of env runners and learners (an idle machine)", bench_scale),
    "learn": ("learner samples/s, one torch thread, beside plain-torch baselines", bench_learn),
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.bench", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("target", choices=list(TARGETS), help="what to measure")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)
    if not REFERENCE_SPEED.exists():
        return report_error(f"reference figures not found at {REFERENCE_SPEED}")
    title, measure = TARGETS[args.target]
    result = measure()
    if args.json:
        print(json.dumps(result))
    else:
        _print(title, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
