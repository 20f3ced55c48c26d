"""The trained module: the paper's policy CNN and a separate value CNN, no shared trunk.

pi is `PommerNet(6)` (the same class behaviour cloning trains, so its state_dict loads as is), vf
a `PommerNet(1)` of its own, so value learning never moves the imitation policy. pi's weights come
from `model_config["pi_weights"]`, loaded only where the module is trained: env runners hold
inference-only copies that the weight sync fills, so a cluster node needs no weights file.

`set_pi_frozen` serves the value warm-up (paper: 10,000 games with pi fixed while vf learns). It
sets `requires_grad`, which checkpoints do not keep, so the curriculum callback re-applies it after
every restore and every iteration.
"""

from __future__ import annotations

import torch
from ray.rllib.core.columns import Columns
from ray.rllib.core.rl_module.apis import ValueFunctionAPI
from ray.rllib.core.rl_module.torch import TorchRLModule

from ..learned import load_policy_net
from ..network import PommerNet

LEARNER = "learner"


class PommerPPOModule(TorchRLModule, ValueFunctionAPI):
    def setup(self):
        self.pi = PommerNet(6, dropout=0.0)
        self.vf = PommerNet(1)
        weights = self.model_config.get("pi_weights")
        if weights and not self.inference_only:
            self.pi.load_state_dict(load_policy_net(weights).state_dict())

    def _forward(self, batch, **kwargs):
        return {Columns.ACTION_DIST_INPUTS: self.pi(batch[Columns.OBS]["planes"])}

    def compute_values(self, batch, embeddings=None) -> torch.Tensor:
        return self.vf(batch[Columns.OBS]["planes"]).squeeze(-1)

    def set_pi_frozen(self, frozen: bool) -> None:
        for parameter in self.pi.parameters():
            parameter.requires_grad_(not frozen)

    @property
    def pi_frozen(self) -> bool:
        return not any(p.requires_grad for p in self.pi.parameters())
