"""The registered env with RLlib's default model: `observation = "planes_last"` gives the planes
alone as a channels-last Box, which RLlib's default CNN encoder reads (the training's default Dict
observation has no default encoder)."""

from __future__ import annotations

import pytest
from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module import DefaultPPOTorchRLModule
from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

from rllib_pommer.curriculum.names import ENV_NAME
from rllib_pommer.rl.env import PommeEnv


def _config(observation: str) -> PPOConfig:
    return (
        PPOConfig()
        .environment(ENV_NAME, env_config={"observation": observation, "max_steps": 40})
        .env_runners(num_env_runners=0)
        .multi_agent(policies={"shared"},
                     policy_mapping_fn=lambda agent_id, episode, **kwargs: "shared")
        # 11x11 boards have no RLlib default filters; the model class stays RLlib's default.
        .rl_module(model_config=DefaultModelConfig(conv_filters=[[16, [3, 3], 1],
                                                                 [32, [3, 3], 2]]))
        .training(train_batch_size_per_learner=160, minibatch_size=80, num_epochs=1)
    )


def test_default_model_trains_on_the_planes(ray_session):
    algo = _config("planes_last").build_algo()
    try:
        result = algo.train()
        assert isinstance(algo.get_module("shared"), DefaultPPOTorchRLModule)
        assert result["env_runners"]["num_env_steps_sampled"] >= 160
        assert "shared" in result["learners"]
    finally:
        algo.stop()


def test_default_model_refuses_the_dict_observation(ray_session):
    with pytest.raises(ValueError, match="No default encoder config"):
        _config("dict").build_algo()


def test_the_training_default_is_unchanged():
    assert set(PommeEnv().observation_spaces[0].spaces) == {"planes", "raw"}
