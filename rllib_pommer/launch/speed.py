"""PPO's speed under RLlib, for `bench train` and `bench learn`: the whole loop (real env against a
zero-cost twin) and the learner (`launch/scale.py` places them on the machine in every way).

`learner_speeds` times the real learner alone: RLlib's `LearnerGroup.update` (learner connector
with the advantage estimation, then `num_epochs` passes of minibatches of 128 through the real
`PommerPPOModule`) on batches the real env runner sampled with the quick curriculum's config, with
pi trainable and with pi frozen (the value warm-up), beside the plain-torch baselines of
`imitation/speed.py` on the same thread count. Samples/s count learner rows times epochs. It also
times the learner connector alone on one iteration's episodes, with its `TrainedAgentsOnly` head
and without it (every agent's rows built, then the fixed seats' dropped, as RLlib does).

`train_speeds(iterations)` builds the PPO config of a curriculum (default "quick", first stage:
all four agents exposed, SimpleAgent opponents as stateful fixed modules, the learner's filters)
twice, once on the real env and once on `ZeroCostEnv`, which has the same spaces, agents and
infos but replays one precomputed observation and ends episodes after the real run's mean episode
length. Everything else (module inference, connectors, fixed modules, learner updates) is
identical, so the ratio of env steps/s says how much of the budget the game and featurizer take
(goal: >= 0.85). Pi starts from random weights; speed does not depend on them.
"""

from __future__ import annotations

import copy
import statistics
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import ray
import torch
from ray.rllib.execution.rollout_ops import synchronous_parallel_sample
from ray.tune.registry import register_env

from ..curriculum.curriculum import load_curriculum
from ..curriculum.names import ENV_NAME, LEARNER
from ..curriculum.settings import RunSettings
from ..imitation import speed as imitation_speed
from ..imitation.network import PommerNet
from ..rl.config import build_config
from ..rl.env import PommeEnv
from ..rl.trained_agents import every_agent_pipeline
from .training import init_ray

ZERO_COST_ENV = "pommerman_team_zero_cost"


class ZeroCostEnv(PommeEnv):
    """env_config["episode_length"]: steps per episode; no deaths, rewards 0, a tie at the end."""

    def __init__(self, config: dict | None = None):
        super().__init__(config)
        self._length = int((config or {}).get("episode_length", 100))
        self._obs, self._infos = super().reset(seed=0)
        self._t = 0

    def reset(self, *, seed=None, options=None):
        self._t = 0
        self.agents = list(self.possible_agents)
        return self._obs, self._infos

    def step(self, action_dict):
        self._t += 1
        done = self._t >= self._length
        infos = {a: {**self._infos[a], **({"winners": []} if done else {})} for a in action_dict}
        return ({a: self._obs[a] for a in action_dict}, dict.fromkeys(action_dict, 0.0),
                {**dict.fromkeys(action_dict, done), "__all__": done}, {"__all__": False}, infos)


register_env(ZERO_COST_ENV, ZeroCostEnv)


def _steps_per_second(config, iterations: int) -> tuple[float, float]:
    """(env steps/s over `iterations` timed iterations after one warm-up, mean episode length)."""
    algo = config.build_algo()
    try:
        algo.train()
        steps, lengths, start = 0.0, [], time.perf_counter()
        for _ in range(iterations):
            runners = algo.train()["env_runners"]
            steps += runners["num_env_steps_sampled"]
            lengths.append(float(runners.get("episode_len_mean", 0.0)))
        return float(steps) / (time.perf_counter() - start), sum(lengths) / len(lengths)
    finally:
        algo.stop()


@contextmanager
def random_pi_weights(num_cpus: int = RunSettings.num_cpus) -> Iterator[Path]:
    """Ray running (started here with `num_cpus` CPUs unless it is already) and a random pi's
    weights file: speed does not depend on the weights."""
    started_ray = not ray.is_initialized()
    if started_ray:
        init_ray(None, num_cpus=num_cpus)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            weights = Path(tmp) / "pi.pt"
            torch.save(PommerNet().state_dict(), weights)
            yield weights
    finally:
        if started_ray:
            ray.shutdown()


def train_speeds(iterations: int = 3, curriculum: str = "quick") -> dict:
    """Env steps/s of PPO on the real and the zero-cost env, and their ratio."""
    with random_pi_weights() as weights:
        plan = load_curriculum(curriculum)
        real, episode_length = _steps_per_second(
            build_config(plan, pi_weights=weights, env=ENV_NAME), iterations)
        zero_config = build_config(plan, pi_weights=weights, env=ZERO_COST_ENV)
        zero_config.environment(env_config={**zero_config.env_config,
                                            "episode_length": max(int(episode_length), 1)})
        zero, _ = _steps_per_second(zero_config, iterations)
    return {"curriculum": curriculum, "iterations": iterations,
            "mean_episode_length": round(float(episode_length), 1),
            "real_env_steps_per_s": round(real, 1), "zero_cost_env_steps_per_s": round(zero, 1),
            "ratio": round(real / zero, 3)}


def learner_rows(episodes) -> int:
    return sum(len(e) for episode in episodes for e in episode.agent_episodes.values()
               if e.module_id == LEARNER)


def sample_iteration(algo) -> list:
    """One training batch's episodes, sampled as the algorithm's iteration does."""
    return synchronous_parallel_sample(
        worker_set=algo.env_runner_group, max_env_steps=algo.config.total_train_batch_size,
        _uses_new_env_runners=True)


def timed_updates(algo, updates: int) -> dict:
    """Sampling and the learner's update timed apart over `updates` iterations' batches after
    one warm-up: env steps sampled and seconds, learner samples (rows times epochs) and
    seconds."""
    config = algo.config
    out = dict.fromkeys(("env_steps", "sampling_s", "learner_samples", "update_s"), 0.0)
    for update in range(updates + 1):
        start = time.perf_counter()
        episodes = sample_iteration(algo)
        sampled = time.perf_counter()
        algo.learner_group.update(episodes=episodes, num_epochs=config.num_epochs,
                                  minibatch_size=config.minibatch_size,
                                  shuffle_batch_per_epoch=True)
        if update:
            out["env_steps"] += sum(map(len, episodes))
            out["sampling_s"] += sampled - start
            out["update_s"] += time.perf_counter() - sampled
            out["learner_samples"] += learner_rows(episodes) * config.num_epochs
    return out


def _learner_samples_per_s(algo, frozen: bool, updates: int) -> float:
    algo.learner_group.foreach_learner(lambda l: l.module[LEARNER].set_pi_frozen(frozen))
    timed = timed_updates(algo, updates)
    return timed["learner_samples"] / timed["update_s"]


def _connector_seconds(algo, repeats: int) -> dict:
    """Median seconds of the learner connector on one iteration's episodes (fresh copies each
    time: the pipeline extends them), with its first piece (TrainedAgentsOnly) and without."""
    learner = algo.learner_group._learner  # the local learner: no remote learners here
    full = learner._learner_connector
    all_agents = every_agent_pipeline(full)
    episodes = sample_iteration(algo)
    times = {"trained_agents": [], "all_agents": []}
    for _ in range(repeats):
        for name, pipeline in (("trained_agents", full), ("all_agents", all_agents)):
            batch_episodes = copy.deepcopy(episodes)
            start = time.perf_counter()
            pipeline(rl_module=learner.module, batch={}, episodes=batch_episodes,
                     shared_data={}, metrics=learner.metrics)
            times[name].append(time.perf_counter() - start)
    trained, every = (statistics.median(times[k]) for k in ("trained_agents", "all_agents"))
    return {"learner_connector_s": trained, "learner_connector_all_agents_s": every,
            "learner_connector_speedup": every / trained}


def _rllib_learner_speeds(updates: int, curriculum: str) -> dict:
    """Learner samples/s of the real RLlib update, pi trainable and pi frozen, and the seconds
    of its connector."""
    with random_pi_weights() as weights:
        algo = build_config(load_curriculum(curriculum), pi_weights=weights).build_algo()
        try:
            trainable = _learner_samples_per_s(algo, False, updates)
            frozen = _learner_samples_per_s(algo, True, updates)
            connector = _connector_seconds(algo, repeats=updates)
        finally:
            algo.stop()
    return {"ppo_samples_per_s": trainable, "ppo_frozen_pi_samples_per_s": frozen, **connector}


def learner_speeds(updates: int = 3, curriculum: str = "quick") -> dict:
    """Learner samples/s on a training run's torch threads: RLlib's PPO update and behaviour
    cloning, each beside its plain-torch baseline, and the float32 FLOP bound of this core."""
    threads = RunSettings().torch_threads
    torch.set_num_threads(threads)
    torch.set_flush_denormal(True)
    result = {"torch_threads": threads, **_rllib_learner_speeds(updates, curriculum)}
    result["ppo_baseline_samples_per_s"] = imitation_speed.plain_ppo_samples_per_s(
        load_curriculum(curriculum).ppo)
    result.update(imitation_speed.bc_speeds())
    result.update(imitation_speed.flop_bound())
    result["ppo_speedup"] = result["ppo_samples_per_s"] / result["ppo_baseline_samples_per_s"]
    result["bc_speedup"] = result["bc_samples_per_s"] / result["bc_baseline_samples_per_s"]
    return {k: round(v, 3) if isinstance(v, float) else v for k, v in result.items()}
