"""The trained module: the paper's policy CNN and a separate value CNN, no shared trunk.

pi is `PommerNet(6)` (the same class behaviour cloning trains, so its state_dict loads as is), vf
a `PommerNet(1)` of its own, so value learning never moves the imitation policy. pi's starting
weights come from `model_config["pi_weights"]`, loaded only where the module is trained: env
runners hold inference-only copies that the weight sync fills, so a cluster node needs no weights
file.

A checkpoint is self-contained: it holds pi and vf as trained, and restoring one (Tune's resume,
`Algorithm.from_checkpoint`, `RLModule.from_checkpoint`) rebuilds the module from the model config
saved with it, whose `pi_weights` is an absolute path on the machine that started the run, then
overwrites every weight with the checkpoint's. So a weights file that is missing at build time is
not an error here: pi starts empty and `pi_source` says so, until `set_state` fills it. Only a
module that is about to be trained with neither source is wrong, and the learner refuses that
(`require_pi`); a new run's weights file is checked before Ray starts (config.check_weights).

Precision and speed: both networks keep their tensors channels-last, which oneDNN's CPU
convolutions run faster than NCHW, and vf runs under bfloat16 autocast on the device its inputs
are on (a learner's GPU too, where it has bfloat16: `vf_autocast`). pi runs in float32, on
the env runners as in the learner, because PPO's ratio compares pi's log-probabilities before and
after updates through a clip of 1 +- 0.01, and bfloat16 rounds a logit of magnitude m to a step
of up to m/128: rounding alone moves the log-probabilities of rare actions (those a filter
override puts into the batch) far past the clip, and with a negative advantage PPO weights a row
by its whole ratio. Float32 removes the rounding (its results differ across batch sizes far
inside the clip), and `learner.py`'s dual clip bounds such rows. The measurements
(`benchmarks/logit_precision.py`, the paper campaign's collapse): docs/measurements.md.

With memory (a curriculum's `memory = true`: the env's planes are 22, `imitation/recall.py`) both
nets read 22 planes, and 19-plane weights files start them with the memory planes unheard
(`network.widened`), so the run starts as the policy it continues plays.

A curriculum may also name `vf_weights`, a value network's state_dict, for a run that continues
another's (its pi and vf exported from a checkpoint) without a value warm-up; like pi's file it
is read only where the module is trained, and a restore overwrites it.

In TeamRadio (the env's `game = "radio"`, seen here as its `MultiDiscrete([6, 8, 8])` action
space) pi is a `RadioNet` that hears the teammate's words and speaks two, and vf a `RadioNet`
that hears them: the action distribution is RLlib's multi-categorical over [move, word, word]
(one 6-way and two 8-way categoricals on the 22 logits), and Team weights files start both nets
with the Team net's outputs exactly (`imitation/network.py`), a radio run's files as they are.

`set_pi_frozen` serves the value warm-up (paper: 10,000 games with pi fixed while vf learns). It
sets `requires_grad`, which checkpoints do not keep, so the curriculum callback re-applies it after
every restore and every iteration.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import torch
from ray.rllib.core.columns import Columns
from ray.rllib.core.distribution.torch.torch_distribution import TorchMultiCategorical
from ray.rllib.core.rl_module.apis import ValueFunctionAPI
from ray.rllib.core.rl_module.torch import TorchRLModule

from ..imitation.learned import load_policy_net
from ..imitation.network import build_net


def vf_autocast(device: str) -> bool:
    """Whether vf runs under bfloat16 autocast on `device` ("cpu", "cuda"): on the CPU, and on a
    GPU that computes in bfloat16 (an older one runs vf in float32)."""
    return device == "cpu" or (device == "cuda" and torch.cuda.is_bf16_supported())


class PommerPPOModule(TorchRLModule, ValueFunctionAPI):
    """The PPO learner module: pi (the paper's CNN, from the imitation weights) in float32 and a
    separate value CNN under bfloat16 autocast, both channels-last (module docstring)."""
    def setup(self):
        self.radio = isinstance(self.action_space, gym.spaces.MultiDiscrete)
        planes = self.observation_space["planes"].shape[0]  # 19, or 22 with memory
        self.pi = build_net(6, self.radio, planes).to(memory_format=torch.channels_last)
        self.vf = build_net(1, self.radio, planes).to(memory_format=torch.channels_last)
        if self.radio:  # [move, word, word]: a categorical each (module docstring)
            self.action_dist_cls = TorchMultiCategorical.get_partial_dist_cls(
                input_lens=[int(n) for n in self.action_space.nvec])
        self.pi_source: str | None = None  # where pi's weights came from (module docstring)
        weights = self.model_config.get("pi_weights")
        if weights and not self.inference_only and Path(weights).is_file():
            self.pi.load_state_dict(load_policy_net(weights, radio=self.radio,
                                                    planes=planes).state_dict())
            self.pi_source = f"imitation weights {weights}"
        vf_weights = self.model_config.get("vf_weights")  # a run that continues another's
        if vf_weights and not self.inference_only and Path(vf_weights).is_file():
            self.vf.load_state_dict(load_policy_net(vf_weights, num_outputs=1, radio=self.radio,
                                                    planes=planes).state_dict())

    def set_state(self, state) -> None:
        super().set_state(state)
        self.pi_source = "checkpoint"

    def require_pi(self) -> None:
        """Refuse to train a pi that neither the imitation weights nor a checkpoint filled."""
        if self.pi_source is None:
            raise ValueError(
                f"the learner's pi has no weights: the imitation weights "
                f"{self.model_config.get('pi_weights')} were not found when the module was built, "
                f"and no checkpoint was restored into it (start a new run where that file exists, "
                f"or pass --pi-weights)")

    def _inputs(self, batch) -> tuple[torch.Tensor, ...]:
        """The networks' inputs: the planes channels-last, and in TeamRadio the words heard."""
        obs = batch[Columns.OBS]
        planes = obs["planes"].contiguous(memory_format=torch.channels_last)
        return (planes, obs["message"]) if self.radio else (planes,)

    def _forward(self, batch, **kwargs):
        return {Columns.ACTION_DIST_INPUTS: self.pi(*self._inputs(batch))}

    def compute_values(self, batch, embeddings=None) -> torch.Tensor:
        inputs = self._inputs(batch)
        device = inputs[0].device.type
        with torch.autocast(device, dtype=torch.bfloat16, enabled=vf_autocast(device)):
            return self.vf(*inputs).squeeze(-1).float()

    def set_pi_frozen(self, frozen: bool) -> None:
        for parameter in self.pi.parameters():
            parameter.requires_grad_(not frozen)

    @property
    def pi_frozen(self) -> bool:
        return not any(p.requires_grad for p in self.pi.parameters())
