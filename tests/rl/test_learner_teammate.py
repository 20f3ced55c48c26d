"""A curriculum whose teammate is "learner": both seats of the team are the trained module, each
with its own filters, and the learner's outcome and return are its team's."""

from __future__ import annotations

import numpy as np
import pytest

from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.names import LEARNER
from rllib_pommer.rl.config import build_config
from rllib_pommer.rl.connectors import FILTERS_KEY

from .conftest import ECHO_ENV

TEAM_SMOKE = """
name = "team_smoke"
description = "Both seats trained, test-sized."
max_steps = 60
[ppo]
train_batch_size = 400
num_epochs = 1
num_envs_per_env_runner = 4
[defaults]
teammate = "learner"
action_filter = 1.0
jitter = 1.0
[[stage]]
name = "static"
opponent = "static"
episodes = 8
"""


@pytest.fixture(scope="module")
def team_run(ray_session, pi_weights, tmp_path_factory):
    path = tmp_path_factory.mktemp("curriculum") / "team_smoke.toml"
    path.write_text(TEAM_SMOKE)
    curriculum = load_curriculum(path)
    algo = build_config(curriculum, pi_weights=pi_weights, env=ECHO_ENV).build_algo()
    try:
        result = algo.train()
        episodes = algo.env_runner.sample(num_timesteps=240, explore=True)
        yield {"curriculum": curriculum, "result": result, "episodes": episodes,
               "modules": set(algo.config.rl_module_spec.rl_module_specs)}
    finally:
        algo.stop()


def test_a_learner_teammate_is_the_trained_module_not_a_fixed_one(team_run):
    assert team_run["curriculum"].policies() == ["static"]
    assert team_run["modules"] == {LEARNER, "static"}


def test_both_seats_of_the_team_learn_each_with_its_own_filters(team_run):
    checked, both = 0, 0
    for episode in team_run["episodes"]:  # chunks: an agent dead before one is absent from it
        learners = sorted(a for a, e in episode.agent_episodes.items() if e.module_id == LEARNER)
        assert len({a % 2 for a in learners}) == 1, learners  # teammates
        both += len(learners) == 2
        filters = episode.custom_data[FILTERS_KEY]
        assert set(learners) <= set(filters)
        assert all(f.flags == {"action_filter": True, "jitter": True} for f in filters.values())
        for agent in learners:
            agent_episode = episode.agent_episodes[agent]
            executed = [info["executed"] for info in agent_episode.get_infos()[1:]]
            assert np.asarray(agent_episode.get_actions()).tolist() == executed
            checked += len(executed)
    assert checked > 100 and both > 0


def test_the_outcome_is_the_teams(team_run):
    runners = team_run["result"]["env_runners"]
    rates = [runners[f"learner_{name}"] for name in ("win", "loss", "tie")]
    assert sum(rates) == pytest.approx(1.0)
    assert -1.0 <= runners["learner_return"] <= 1.0  # the mean of two agents' returns
    assert runners["learner_jitter_on"] == 1.0


def test_only_a_teammate_may_be_the_learner(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(TEAM_SMOKE.replace('opponent = "static"', 'opponent = "learner"'))
    with pytest.raises(ValueError, match="key 'opponent': unknown policy 'learner'"):
        load_curriculum(path)
    path.write_text(TEAM_SMOKE.replace('teammate = "learner"', 'teammate = "lerner"'))
    with pytest.raises(ValueError, match="'teammate' \\(a policy, or 'learner'"):
        load_curriculum(path)
