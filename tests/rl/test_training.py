"""A smoke run in-process: stage boundary, warm-up freeze, the filter connector, checkpoint ->
restore -> arena."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from rllib_pommer.arena.match import MatchSpec, play_match
from rllib_pommer.curriculum.names import LEARNER
from rllib_pommer.runs.checkpoints import load_checkpoint_net

from .conftest import learner_episodes, log_softmax, smoke_run


@pytest.fixture(scope="module")
def smoke(ray_session, pi_weights, tmp_path_factory):
    yield smoke_run("smoke", pi_weights, tmp_path_factory.mktemp("ckpt"))


def test_stage_boundary_and_warmup_freeze(smoke):
    iterations = smoke["iterations"]
    stages = [it["stage"] for it in iterations]
    assert stages[0] == 0 and stages[-1] == 1
    # The new stage's mapping is on the env runner; RLlib's frozen algorithm config is left as
    # built (the callback no longer unfreezes it).
    assert smoke["mappings"] == (0, 1)
    for it in iterations:
        assert it["vf_changed"]
        assert it["pi_changed"] == (it["stage"] == 1), "pi must move only after the warm-up"
        played = it["result"]["curriculum"]["iteration_stage_name"]
        assert played == smoke["curriculum"].stages[it["stage"]].name
    last = iterations[-1]["result"]["env_runners"]
    assert {"learner_win", "learner_loss", "learner_tie", "learner_return", "learner_bombs",
            "learner_kills", "learner_suicides", "learner_opponent_suicides"} <= set(last)
    for it in iterations:  # the learner's health metrics (learner.py), on every iteration
        health = it["result"]["learners"][LEARNER]
        assert health["nonfinite_updates_skipped"] == 0
        assert 0 < health["pi_logit_spread"] < 1e3
        ratio = health["pi_log_ratio_min"], health["pi_log_ratio_max"]
        if it["stage"] == 0:  # pi frozen: the learner's log-probabilities are the sampler's, up
            # to float32 rounding across batch sizes (rl_module.py: ~1e-5; PPO's clip is 0.01)
            assert -1e-4 < ratio[0] <= 0.0 <= ratio[1] < 1e-4
        else:  # the first minibatch meets pi as it sampled, then pi moves
            assert ratio[0] <= 0.0 <= ratio[1] < 88 and ratio != (0.0, 0.0)
    shares = [it["result"]["env_runners"].get("learner_override_share", 0) for it in iterations]
    assert max(shares) > 0, "the filters never overrode an action"


def test_connector_stores_the_executed_action_with_its_logp(smoke):
    checked = 0
    for agent_episode in learner_episodes(smoke["episodes"]):
        actions = np.asarray(agent_episode.get_actions())
        infos = agent_episode.get_infos()
        executed = [info["executed"] for info in infos[1:]]
        assert actions.tolist() == executed
        logp = np.asarray(agent_episode.get_extra_model_outputs("action_logp"))
        logits = np.asarray(agent_episode.get_extra_model_outputs("action_dist_inputs"))
        expected = log_softmax(logits)[np.arange(len(actions)), actions]
        np.testing.assert_allclose(logp, expected, atol=1e-4)
        checked += len(actions)
    assert checked > 50


def test_checkpoint_restores_stage_and_plays_in_the_arena(smoke):
    algo = smoke["config"].build_algo()
    try:
        algo.restore(smoke["checkpoint"])
        assert algo.env_runner.config.policy_mapping_fn.stage == 1
        assert not algo.learner_group._learner.module[LEARNER].pi_frozen
    finally:
        algo.stop()
    net = load_checkpoint_net(smoke["checkpoint"])
    for key, value in net.state_dict().items():
        assert torch.equal(value, smoke["trained"]["pi"][key])
    records = list(play_match(MatchSpec(team=smoke["checkpoint"], vs="static", games=4),
                              workers=1))
    assert len(records) == 4
