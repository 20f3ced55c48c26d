"""`bench scale` measures each layout where it asks to run: the learner in the algorithm's process
or in learner actors, sampling there or in env runners, with figures a table can show."""

from __future__ import annotations

import pytest

from rllib_pommer.curriculum.settings import RunSettings
from rllib_pommer.launch.scale import ALONE, Layout, layout_hint, project, scale_speeds, scale_table


def test_each_layout_is_measured_and_compared_with_the_first(ray_session):
    layouts = (Layout("local"), Layout("one learner", learners=1))
    result = scale_speeds(iterations=1, updates=1, curriculum="smoke", layouts=layouts,
                          logical_cpus=2)
    rows = result["layouts"]
    assert [row["name"] for row in rows] == ["local", "one learner"]
    assert rows[0]["env_steps_ratio"] == 1.0 and rows[0]["learner_ratio"] == 1.0
    for row in rows:
        assert row["env_steps_per_s"] > 0 and row["sampling_env_steps_per_s"] > 0
        assert row["learner_samples_per_s"] > 0 and row["memory_mib"] > 100
        assert 0 < row["learner_samples_per_env_step"] <= 4  # rows of the learner's seats
    assert rows[1]["command"] == "--num-learners 1"
    assert result["best"] in {row["name"] for row in rows}
    table = scale_table(result)
    assert "| one learner | `--num-learners 1` |" in table and "| 128 |" in table


def test_projections_divide_both_phases_over_the_cores():
    one_core = {"sampling_env_steps_per_s": 400.0, "learner_samples_per_s": 800.0,
                "learner_samples_per_env_step": 4.0}
    # 4,000 env steps: 10 s sampling, 20 s update on one core
    assert project(one_core, 4000, 2)["iteration_s"] == pytest.approx(30.0)
    eight = project(one_core, 4000, 8)
    assert eight["iteration_s"] == pytest.approx(30 / 7, abs=0.01)
    assert eight["update_share"] == pytest.approx(2 / 3, abs=1e-3)


def test_train_names_the_faster_layout_only_to_a_default_run_with_cores_to_spare():
    hint = layout_hint(RunSettings(), cores=2)
    assert hint and ALONE.command in hint and "--num-env-runners 2 --torch-threads 2" in hint
    assert layout_hint(RunSettings(), cores=1) is None
    assert layout_hint(RunSettings(num_env_runners=2, torch_threads=2), cores=2) is None
    assert layout_hint(RunSettings(address="10.0.0.1:6379"), cores=8) is None
