"""Kickstarting (rl/teacher.py): a curriculum's teacher is checked, its moves on the learner's
steps are what an agent of that policy, seeded as the connector seeds it, plays from the same
observations in order, and the learner adds their cross-entropy to the learner's loss."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.names import LEARNER
from rllib_pommer.game.raw_codec import unpack_raw
from rllib_pommer.rl.config import build_config
from rllib_pommer.rl.teacher import TEACHER_COLUMN, teacher_agent, teacher_loss

from .test_self_play import SELF_PLAY_SMOKE

# The self-play smoke league, its learner taught by SimpleAgent (cheap, and seeded like search).
TEACHER_SMOKE = SELF_PLAY_SMOKE.replace(
    "num_envs_per_env_runner = 4\n",
    'num_envs_per_env_runner = 4\nteacher = "simple"\nteacher_weight = 2.0\n')


def test_a_teacher_is_checked(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(TEACHER_SMOKE)
    ppo = load_curriculum(path).ppo
    assert (ppo.teacher, ppo.teacher_weight) == ("simple", 2.0)
    for old, new, words in (('teacher = "simple"', 'teacher = "simpel"', "teacher: unknown "
                             "policy 'simpel'"),
                            ("teacher_weight = 2.0", "teacher_weight = -1.0",
                             "teacher_weight")):
        path.write_text(TEACHER_SMOKE.replace(old, new))
        with pytest.raises(ValueError, match=words):
            load_curriculum(path)


def test_the_teacher_loss_is_the_cross_entropy_of_the_moves():
    logits = torch.tensor([[2.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 3.0, 0.0, 0.0, 0.0, 0.0],
                           [9.0, 9.0, 9.0, 9.0, 9.0, 9.0]])
    xent, agreement = teacher_loss(logits, torch.tensor([0, 0, 5]),
                                   torch.tensor([True, True, False]))
    expected = (-torch.log_softmax(logits[0], -1)[0] - torch.log_softmax(logits[1], -1)[0]) / 2
    assert math.isclose(xent.item(), expected.item(), rel_tol=1e-6)
    assert agreement.item() == 0.5


def test_the_learner_is_pulled_toward_the_teachers_moves(ray_session, pi_weights, tmp_path):
    path = tmp_path / "teacher.toml"
    path.write_text(TEACHER_SMOKE)
    algo = build_config(load_curriculum(path), pi_weights=pi_weights).build_algo()
    try:
        results = [algo.train() for _ in range(2)]
        learner = results[-1]["learners"][LEARNER]
        assert math.isfinite(learner["teacher_xent"]) and learner["teacher_xent"] > 0
        assert 0.0 <= learner["teacher_agreement"] <= 1.0
        checked = 0
        for episode in algo.env_runner.sample(num_episodes=4, explore=True):
            for agent_id, agent_episode in episode.agent_episodes.items():
                if episode.module_for(agent_id) != LEARNER:
                    assert TEACHER_COLUMN not in agent_episode.extra_model_outputs
                    continue
                labels = agent_episode.get_extra_model_outputs(TEACHER_COLUMN)
                raws = [obs["raw"] for obs in agent_episode.get_observations()]
                teacher = teacher_agent("simple", agent_id, raws[0])
                replayed = [teacher.act(unpack_raw(raw)) for raw in raws[:len(labels)]]
                assert np.asarray(labels).tolist() == replayed
                checked += len(labels)
        assert checked > 0
    finally:
        algo.stop()
