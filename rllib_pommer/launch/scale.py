"""How a PPO run scales, for `bench scale`: the league curriculum's whole loop and its learner,
for each way of placing sampling and learning on this machine, side by side in one Ray instance.

A layout is a number of remote env runners (0: the algorithm's process samples), of learner actors
(0: the learner lives in the algorithm's process) and the local learner's torch threads. For each
the bench builds the real algorithm on the real env and measures:

- the whole loop's env steps/s over timed iterations after one warm-up (`algo.train()`);
- each phase alone, on one more iteration's batch sampled as the algorithm samples it: sampling's
  env steps/s, and the learner's samples/s (learner rows times epochs a second of
  `LearnerGroup.update`);
- the memory the layout holds: the resident memory of this process and every process below it
  (Ray's daemons and workers) after the iterations.

Ray gets more logical CPUs than the machine has cores (`LOGICAL_CPUS`), so that every layout is
placed as it asks; the cores are what they are, and the bench says how each layout uses them.
From the one-core figures it also projects what the same run needs on larger machines
(`project`): PPO is synchronous, so an iteration costs its sampling over the env runners plus its
update over the learners.
"""

from __future__ import annotations

import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import torch

from ..curriculum.curriculum import load_curriculum
from ..curriculum.names import LEARNER_THREADS_ENV
from ..rl.config import build_config
from .speed import random_pi_weights, timed_updates

LOGICAL_CPUS = 8
CURRICULUM = "league2"  # the league recipe: a league of learned and scripted opponents


@dataclass(frozen=True)
class Layout:
    """Where a run samples and learns."""

    name: str
    env_runners: int = 0
    learners: int = 0
    threads: int = 1  # the local learner's (and in-process sampling's) torch threads

    @property
    def command(self) -> str:
        """The `train` options that ask for this layout."""
        parts = [f"--num-env-runners {self.env_runners}"] if self.env_runners else []
        parts += [f"--num-learners {self.learners}"] if self.learners else []
        parts += [f"--torch-threads {self.threads}"] if self.threads != 1 else []
        return " ".join(parts) or "(the default)"


# The layouts a 2-core machine allows; the first is `train`'s default (one run per core).
LAYOUTS = (
    Layout("local learner, 1 thread"),
    Layout("local learner, 2 threads", threads=2),
    Layout("1 remote learner", learners=1),
    Layout("2 data-parallel learners", learners=2),
    Layout("1 env runner, local learner, 2 threads", env_runners=1, threads=2),
    Layout("2 env runners, local learner, 2 threads", env_runners=2, threads=2),
    Layout("2 env runners, 2 data-parallel learners", env_runners=2, learners=2),
)


def _tree_rss_mib(root: int) -> float:
    """Resident MiB of `root` and every process below it (Linux /proc)."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
                parents[int(entry.name)] = int(fields[1])
            except (OSError, IndexError, ValueError):
                continue
    tree, frontier = {root}, [root]
    while frontier:
        children = [pid for pid, parent in parents.items() if parent in frontier]
        tree.update(children)
        frontier = children
    kib = 0
    for pid in tree:
        try:
            for line in Path(f"/proc/{pid}/status").read_text().splitlines():
                if line.startswith("VmRSS:"):
                    kib += int(line.split()[1])
        except OSError:
            continue
    return kib / 1024


def _phases(algo, updates: int) -> dict:
    """Env steps/s of sampling alone and learner samples/s of the update alone."""
    timed = timed_updates(algo, updates)
    return {"sampling_env_steps_per_s": round(timed["env_steps"] / timed["sampling_s"], 1),
            "learner_samples_per_s": round(timed["learner_samples"] / timed["update_s"], 1),
            "learner_samples_per_env_step": round(timed["learner_samples"]
                                                  / timed["env_steps"], 3)}


def measure(layout: Layout, weights: Path, curriculum: str, iterations: int,
            updates: int) -> dict:
    """One layout's figures (module docstring)."""
    plan = load_curriculum(curriculum)
    config = build_config(plan, pi_weights=weights, num_env_runners=layout.env_runners,
                          cpus_per_env_runner=1.0, num_learners=layout.learners)
    os.environ[LEARNER_THREADS_ENV] = str(layout.threads)  # the local learner reads it
    torch.set_num_threads(layout.threads)
    algo = config.build_algo()
    try:
        algo.train()  # warm-up: compiled kernels, the first batch
        steps, start = 0.0, time.perf_counter()
        for _ in range(iterations):
            steps += algo.train()["env_runners"]["num_env_steps_sampled"]
        loop = steps / (time.perf_counter() - start)
        return {**asdict(layout), "command": layout.command, "env_steps_per_s": round(loop, 1),
                **_phases(algo, updates), "memory_mib": round(_tree_rss_mib(os.getpid()))}
    finally:
        algo.stop()
        del os.environ[LEARNER_THREADS_ENV]


def project(one_core: dict, env_steps: int, cores: int) -> dict:
    """An iteration of `env_steps` on `cores` cores from the default layout's one-core rates:
    `cores - 1` env runners sample while the learners wait, then `cores - 1` data-parallel
    learners update while the runners wait, each at the one-core rate (the ideal: the 2-core
    rows say how near two learners come to it)."""
    sample_s = env_steps / one_core["sampling_env_steps_per_s"]
    update_s = (env_steps * one_core["learner_samples_per_env_step"]
                / one_core["learner_samples_per_s"])
    workers = max(cores - 1, 1)
    seconds = (sample_s + update_s) / workers
    return {"cores": cores, "env_runners": workers, "learners": workers,
            "iteration_s": round(seconds, 2), "env_steps_per_s": round(env_steps / seconds, 1),
            "update_share": round(update_s / (sample_s + update_s), 3)}


def scale_speeds(iterations: int = 2, updates: int = 1, curriculum: str = CURRICULUM,
                 layouts: tuple[Layout, ...] = LAYOUTS, logical_cpus: int = LOGICAL_CPUS) -> dict:
    """Every layout's figures, their ratios to the first (the default), and projections to 8,
    32 and 128 cores, on a Ray instance of `logical_cpus` started here unless one runs."""
    with random_pi_weights(num_cpus=logical_cpus) as weights:
        rows = [measure(layout, weights, curriculum, iterations, updates) for layout in layouts]
    base = rows[0]
    for row in rows:
        row["env_steps_ratio"] = round(row["env_steps_per_s"] / base["env_steps_per_s"], 3)
        row["learner_ratio"] = round(row["learner_samples_per_s"]
                                     / base["learner_samples_per_s"], 3)
    best = max(rows, key=lambda row: row["env_steps_per_s"])
    env_steps = load_curriculum(curriculum).ppo.train_batch_size
    return {"curriculum": curriculum, "iterations": iterations, "logical_cpus": logical_cpus,
            "cores": os.cpu_count(), "layouts": rows, "best": best["name"],
            "best_command": best["command"],
            "projection": [project(base, env_steps, cores) for cores in (8, 32, 128)]}



def scale_table(result: dict) -> str:
    """The layouts as a Markdown table, then the projections."""
    lines = ["| layout | `train` options | env steps/s (x default) | sampling env steps/s | "
             "learner samples/s (x default) | memory MiB |", "|---|---|---|---|---|---|"]
    for row in result["layouts"]:
        lines.append(f"| {row['name']} | `{row['command']}` | {row['env_steps_per_s']} "
                     f"({row['env_steps_ratio']}x) | {row['sampling_env_steps_per_s']} | "
                     f"{row['learner_samples_per_s']} ({row['learner_ratio']}x) | "
                     f"{row['memory_mib']} |")
    lines += ["", "| cores | env runners | learners | iteration s | env steps/s | update share |",
              "|---|---|---|---|---|---|"]
    for row in result["projection"]:
        lines.append(f"| {row['cores']} | {row['env_runners']} | {row['learners']} | "
                     f"{row['iteration_s']} | {row['env_steps_per_s']} | {row['update_share']} |")
    return "\n".join(lines)


# The fastest layout of a run alone on 2 cores (`bench scale`, docs/scaling.md).
ALONE = Layout("2 env runners, local learner, 2 threads", env_runners=2, threads=2)


def layout_hint(settings, cores: int) -> str | None:
    """The line `train` prints for a run that takes the default layout (sampling and learning on
    one core, for one run per core) on its own Ray instance where `cores` >= 2: the layout a run
    alone on the machine should take instead. None otherwise."""
    default = (settings.num_env_runners, settings.num_learners, settings.torch_threads) == (0, 0, 1)
    if settings.address is not None or cores < 2 or not default:
        return None
    return (f"this run samples and learns on one core, the layout for one run per core; a run "
            f"alone on this {cores}-core machine goes faster with remote env runners and more "
            f"learner threads (on 2 cores: {ALONE.command}; docs/scaling.md, and `python -m "
            f"rllib_pommer.bench scale` measures every layout)")
