"""The layout of a run that has a 2-core machine to itself (`--num-env-runners 2 --torch-threads
2`): two remote env runners sample while the learner, on two torch threads, waits, and the
curriculum still reaches every runner (the stage is pushed to each runner's own config). A resumed
run keeps the layout it started with, and says so."""

from __future__ import annotations

import json

import pytest
import torch

from rllib_pommer.rl.config import build_config
from rllib_pommer.rl.curriculum import load_curriculum
from rllib_pommer.rl.settings import RunSettings
from rllib_pommer.rl.training import cpus_per_env_runner, kept_layouts


def test_our_own_ray_instance_shares_its_cpus_between_the_learner_and_the_runners():
    assert cpus_per_env_runner(RunSettings(num_env_runners=2, num_cpus=2)) == 0.5
    assert cpus_per_env_runner(
        RunSettings(num_env_runners=2, num_cpus=2, torch_threads=2)) == 0.0
    assert cpus_per_env_runner(RunSettings(num_env_runners=2, num_cpus=8)) == 1.0
    assert cpus_per_env_runner(RunSettings(num_env_runners=4, address="auto")) == 1.0
    with pytest.raises(ValueError, match="--torch-threads 3 exceeds --num-cpus 2"):
        RunSettings(torch_threads=3)


def test_a_resumed_run_says_it_keeps_the_layout_it_started_with(tmp_path):
    trial = tmp_path / "PPO_x"
    trial.mkdir()
    (trial / "params.json").write_text(json.dumps({"num_env_runners": 0,
                                                   "num_cpus_for_main_process": 1}))
    asked = RunSettings(resume=True, num_env_runners=2, torch_threads=2)
    (note,) = kept_layouts(tmp_path, asked)
    assert "PPO_x resumes as it started, with 0 env runners and 1 learner threads" in note
    assert kept_layouts(tmp_path, RunSettings(resume=True)) == []
    assert kept_layouts(tmp_path, RunSettings(num_env_runners=2)) == []  # not a resume


def test_a_curriculum_runs_on_two_remote_env_runners_and_a_two_thread_learner(
        ray_session, pi_weights):
    curriculum = load_curriculum("smoke")
    config = build_config(curriculum, pi_weights=pi_weights, num_env_runners=2,
                          cpus_per_env_runner=0.0, learner_cpus=2)
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
