"""PPO's torch learner with four changes: Adam runs fused, its connector batches only the agents it
trains, it never trains a pi without weights, and it skips an update whose gradients are not finite.

RLlib's default optimizer is `torch.optim.Adam` with its per-tensor Python loop; the fused CPU
kernel updates all of a module's parameters in one call: 0.18 ms instead of 0.65 ms per minibatch
for pi and vf together (one thread), the same arithmetic.

Its learner connector starts with `TrainedAgentsOnly` (trained_agents.py, with the measurement),
set here rather than in the config so that runs restored with an older config get it.

Before every update the learner module must have its pi from the imitation weights or from a
restored checkpoint (rl_module.py: a restore builds the module before it loads the checkpoint, so
a missing weights file is only an error once training would start from random weights).

A minibatch with a non-finite gradient is skipped whole: no optimizer step, Adam's moments kept.
RLlib's default instead replaces nan by 0 and inf by the largest float32 and steps, which sets
Adam's second moment of every such weight to inf for good; its `torch_skip_nan_gradients=True`
does not help, as RLlib 2.60 then steps with the non-finite gradients as they are (and a restored
run keeps the config it started with). The paper campaign's first run met
this at 81,100 games (6,770 warnings until 100,000): from then its training win rate against
SimpleAgent fell from 0.76 to 0.24 and pi's logit spread (largest minus smallest logit, median
over the decisions of 16 games) grew from about 20 to 8,100, so that it never placed a bomb against
StaticAgent. Each iteration logs how many updates it skipped (`nonfinite_updates_skipped`) and
the largest batch-mean logit spread pi produced (`pi_logit_spread`), and the extremes of PPO's
log-ratio (`pi_log_ratio_max`, `pi_log_ratio_min`: `_log_pi_health`), all kept in history.csv.
"""

from __future__ import annotations

import os

import torch
from ray.rllib.algorithms.ppo.torch.ppo_torch_learner import PPOTorchLearner
from ray.rllib.core.columns import Columns

from .names import LEARNER_THREADS_ENV
from .rl_module import LEARNER
from .trained_agents import TrainedAgentsOnly


class PommerPPOLearner(PPOTorchLearner):
    """RLlib's PPO torch learner with a fused Adam per module and a connector that batches the
    trained agents only, which refuses to train a learner module whose pi has no weights (module
    docstring)."""
    def build(self) -> None:
        # Ray gives the algorithm's process, where this learner lives (and samples, without
        # remote env runners), one OpenMP thread per CPU it holds (one); `train
        # --torch-threads` says how many it may use.
        torch.set_num_threads(int(os.environ.get(LEARNER_THREADS_ENV, "1")))
        super().build()
        self._learner_connector.prepend(TrainedAgentsOnly(self.should_module_be_updated))

    def configure_optimizers_for_module(self, module_id, config=None) -> None:
        params = self.get_parameters(self._module[module_id])
        self.register_optimizer(module_id=module_id,
                                optimizer=torch.optim.Adam(params, fused=True), params=params,
                                lr_or_lr_schedule=config.lr)

    def compute_loss_for_module(self, *, module_id, config, batch, fwd_out):
        if module_id == LEARNER:
            self._log_pi_health(batch, fwd_out[Columns.ACTION_DIST_INPUTS].detach())
        return super().compute_loss_for_module(module_id=module_id, config=config, batch=batch,
                                               fwd_out=fwd_out)

    def _log_pi_health(self, batch, logits: torch.Tensor) -> None:
        """Per iteration: the largest batch-mean logit spread, and the extremes of PPO's log-ratio
        (log pi(a) now minus when sampled) over the rows it trains on: a log-ratio above 88
        overflows PPO's float32 ratio to inf, whose backward is nan even where the clip or the
        min leaves that row's gradient at zero (the suspected trigger of the collapse above)."""
        spread = (logits.max(-1).values - logits.min(-1).values).mean()
        self.metrics.log_value((LEARNER, "pi_logit_spread"), spread.item(), reduce="max")
        dist = self.module[LEARNER].unwrapped().get_train_action_dist_cls().from_logits(logits)
        log_ratio = dist.logp(batch[Columns.ACTIONS]) - batch[Columns.ACTION_LOGP]  # as PPO's
        if Columns.LOSS_MASK in batch:
            log_ratio = log_ratio[batch[Columns.LOSS_MASK].bool()]
        if log_ratio.numel():
            self.metrics.log_value((LEARNER, "pi_log_ratio_max"), log_ratio.max().item(),
                                   reduce="max")
            self.metrics.log_value((LEARNER, "pi_log_ratio_min"), log_ratio.min().item(),
                                   reduce="min")

    def apply_gradients(self, gradients_dict) -> None:
        finite = all(grad is None or torch.isfinite(grad).all()
                     for grad in gradients_dict.values())
        self.metrics.log_value((LEARNER, "nonfinite_updates_skipped"), int(not finite),
                               reduce="sum")
        if finite:  # else no step: the next minibatch's backward starts from zeroed gradients
            super().apply_gradients(gradients_dict)

    def before_gradient_based_update(self, *, timesteps) -> None:
        super().before_gradient_based_update(timesteps=timesteps)
        self.module[LEARNER].unwrapped().require_pi()
