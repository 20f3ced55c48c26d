"""The layout of a run that has a 2-core machine to itself (`--num-env-runners 2 --torch-threads
2`): two remote env runners sample while the learner, on two torch threads, waits, and the
curriculum still reaches every runner (the stage is pushed to each runner's own config). A resumed
run keeps the layout it started with, and says so."""

from __future__ import annotations

import subprocess
import sys

import pytest
import torch

from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.names import LEARNER_THREADS_ENV
from rllib_pommer.curriculum.settings import RunSettings
from rllib_pommer.launch.training import cpus_per_env_runner
from rllib_pommer.rl.config import build_config


def test_our_own_ray_instance_shares_its_cpus_between_the_learner_and_the_runners():
    assert cpus_per_env_runner(RunSettings(num_env_runners=2, num_cpus=2)) == 0.5
    assert cpus_per_env_runner(RunSettings(num_env_runners=2, num_cpus=8)) == 1.0
    assert cpus_per_env_runner(RunSettings(num_env_runners=4, address="auto")) == 1.0
    with pytest.raises(ValueError, match="--torch-threads 3 exceeds --num-cpus 2"):
        RunSettings(torch_threads=3)
    # the learner's process takes one Ray CPU: no room for a runner on a 1-CPU instance
    with pytest.raises(ValueError, match="--num-env-runners 1 needs --num-cpus 2 or more"):
        RunSettings(num_env_runners=1, num_cpus=1)
    assert RunSettings(num_cpus=1).num_env_runners == 0  # sampling in its process: fine
    assert RunSettings(num_env_runners=1, num_cpus=1, address="auto").num_cpus == 1  # a cluster


def test_tune_can_place_the_two_runner_layout_on_two_cpus(pi_weights):
    """Tune asks Ray for a placement group of the algorithm's bundles: each must hold some
    resource (Ray refuses an empty one) and together they must fit our own Ray's 2 CPUs."""
    layout = RunSettings(num_env_runners=2, torch_threads=2)
    config = build_config(load_curriculum("smoke"), pi_weights=pi_weights, num_env_runners=2,
                          cpus_per_env_runner=cpus_per_env_runner(layout))
    bundles = config.algo_class.default_resource_request(config).bundles
    assert len(bundles) == 3 and all(any(v > 0 for v in b.values()) for b in bundles)
    assert sum(b.get("CPU", 0) for b in bundles) <= layout.num_cpus


def test_a_curriculum_runs_on_two_remote_env_runners_and_a_two_thread_learner(
        ray_session, pi_weights, monkeypatch):
    curriculum = load_curriculum("smoke")
    config = build_config(curriculum, pi_weights=pi_weights, num_env_runners=2,
                          cpus_per_env_runner=0.5)
    monkeypatch.setenv(LEARNER_THREADS_ENV, "2")  # what init_ray gives the run's processes
    algo = config.build_algo()
    try:
        results = []
        while not results or results[-1]["curriculum"]["episodes"] < curriculum.total_episodes:
            results.append(algo.train())
        assert algo.env_runner_group.num_remote_env_runners() == 2
        stages = algo.env_runner_group.foreach_env_runner(
            lambda runner: runner.config.policy_mapping_fn.stage, local_env_runner=False)
        threads = [r.get() for r in algo.learner_group.foreach_learner(
            lambda learner: torch.get_num_threads())]
    finally:
        algo.stop()
    assert stages == [1, 1], "each remote runner must have the second stage's mapping"
    assert threads == [2]
    assert results[0]["curriculum"]["iteration_stage_name"] == "warmup"
    last = results[-1]
    assert last["curriculum"]["iteration_stage_name"] == "static"
    assert last["env_runners"]["num_module_steps_sampled"]["static"] > 0
    assert {"learner_win", "learner_loss", "learner_tie"} <= set(last["env_runners"])


def test_init_ray_hands_the_learner_threads_to_every_process_of_the_run():
    code = ("import os, ray\nfrom rllib_pommer.launch.training import init_ray\n"
            "init_ray(None, torch_threads=2)\n"
            f"read = ray.remote(lambda: os.environ.get({LEARNER_THREADS_ENV!r}))\n"
            "print(ray.get(read.remote()))\n"
            "ray.shutdown()\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == "2"
