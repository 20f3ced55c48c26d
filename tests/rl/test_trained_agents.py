"""The learner connector batches the trained agents only, and their rows are unchanged by it."""

from __future__ import annotations

import copy

import numpy as np
import torch
import tree

from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.names import LEARNER
from rllib_pommer.rl.config import build_config
from rllib_pommer.rl.trained_agents import TrainedAgentsOnly, every_agent_pipeline


def _run(pipeline, learner, episodes):
    return pipeline(rl_module=learner.module, batch={}, episodes=episodes, shared_data={},
                    metrics=learner.metrics)


def _columns(module_batch) -> dict:
    return {path: np.asarray(torch.as_tensor(value))
            for path, value in tree.flatten_with_path(module_batch)}


def test_learner_batch_is_the_trained_agents_rows_of_the_default_pipeline(ray_session,
                                                                           pi_weights):
    algo = build_config(load_curriculum("smoke"), pi_weights=pi_weights).build_algo()
    try:
        learner = algo.learner_group._learner
        full = learner._learner_connector
        assert isinstance(full.connectors[0], TrainedAgentsOnly)
        default = every_agent_pipeline(full)
        episodes = algo.env_runner.sample(num_timesteps=400, explore=True)
        seats = {episode.id_: set(episode.agent_episodes) for episode in episodes}
        assert any(len(agents) == 4 for agents in seats.values())

        trimmed_input = copy.deepcopy(episodes)
        originals = list(trimmed_input)
        trimmed = _run(full, learner, trimmed_input)
        every = _run(default, learner, copy.deepcopy(episodes))
    finally:
        algo.stop()

    assert set(every) == {LEARNER, "simple", "suicide"}  # what RLlib builds, then drops
    assert set(trimmed) == {LEARNER}
    ours, theirs = _columns(trimmed[LEARNER]), _columns(every[LEARNER])
    assert set(ours) == set(theirs) and len(ours) > 5
    for path, column in theirs.items():
        np.testing.assert_array_equal(ours[path], column, err_msg=str(path))
    # The env runner sums an episode's chunks into its metrics: the episodes stay whole.
    assert [set(e.agent_episodes) for e in originals] == [seats[e.id_] for e in episodes]
    assert all(single.module_id == LEARNER
               for view in trimmed_input for single in view.agent_episodes.values())
