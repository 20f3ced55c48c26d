"""PPO's torch learner with five changes: Adam runs fused, its connector batches only the agents it
trains, it never trains a pi without weights, it skips an update whose gradients are not finite,
and it can bound the ratio of rows with a negative advantage (dual clip, off by default).

RLlib's default optimizer is `torch.optim.Adam` with its per-tensor Python loop; the fused CPU
kernel updates all of a module's parameters in one call, the same arithmetic in a fraction of the
time (docs/measurements.md).

Its learner connector starts with `TrainedAgentsOnly` (trained_agents.py),
set here rather than in the config so that runs restored with an older config get it.

Before every update the learner module must have its pi from the imitation weights or from a
restored checkpoint (rl_module.py: a restore builds the module before it loads the checkpoint, so
a missing weights file is only an error once training would start from random weights).

A minibatch with a non-finite gradient is skipped whole: no optimizer step, Adam's moments kept.
RLlib's default instead replaces nan by 0 and inf by the largest float32 and steps, which sets
Adam's second moment of every such weight to inf for good; its `torch_skip_nan_gradients=True`
does not help, as RLlib 2.60 then steps with the non-finite gradients as they are (and a restored
run keeps the config it started with). One such step ruins pi for good: the training win rate
collapses and pi's logit spread (largest minus smallest logit) grows by orders of magnitude, as
in the paper campaign's first run (docs/measurements.md). Each iteration logs how many updates
it skipped (`nonfinite_updates_skipped`) and the largest batch-mean logit spread pi produced
(`pi_logit_spread`), and the extremes of PPO's log-ratio (`pi_log_ratio_max`,
`pi_log_ratio_min`: `_log_pi_health`), all kept in history.csv, and the same extremes over the
rows whose action pi gave a log-probability below -10 when it sampled (`pi_rare_log_ratio_max`,
`_min`; `pi_rare_rows` counts them once per epoch): at ~3,500 rows per iteration pi itself draws
such an action about once in a thousand iterations, so these are the filters' overrides.

Dual clip (Ye et al. 2020, "Mastering Complex Control in MOBA Games with Deep RL"): PPO's clipped
loss bounds the ratio r of a row with a positive advantage, but weights a row with a negative
advantage A by the whole r, so a row whose probability grew by e^20 since it was sampled pulls
with 5e8 times its share. The dual-clip loss max(min(rA, clip(r)A), cA) caps that row at cA, a
constant: its gradient is zero. The learner gets the same gradient from RLlib's loss by zeroing
such rows' advantages (`dual_clipped`; the loss value differs by a constant). `dual_clip` in a
curriculum's [ppo] table sets c; the default, inf, is PPO as the paper ran it.

Learners beyond one process (`train --num-learners N`, rl/config.py): RLlib's torch learner
wraps every torch module in torch's DistributedDataParallel when N > 1, which does not fit ours:
DDP refuses a module without trainable parameters (the snapshot slots, the frozen nets), expects
the same parameters to receive gradients on every learner in every minibatch (pi frozen after
the wrap, for the value warm-up, never does; an exploiter's rows may reach one learner's shard
and not the other's, and DDP then waits for ever), and hides the module's own attributes behind
the wrapper. So no module is wrapped: the learners start from learner 0's weights (broadcast
when they are built), and after each backward pass `_average_gradients` all-reduces the
gradients of the trained modules' trainable parameters in one flat tensor, each module's
averaged over the learners whose minibatch held its rows (a module no learner saw keeps no
gradient, as on one learner). Every learner then holds the same gradients, so the gradient clip,
the skip of non-finite updates (an inf on one learner is an inf on all) and Adam's step keep
their weights identical, and the league (rl/league.py), which works on every learner alike,
keeps one book. RLlib shards an iteration's episodes over the learners and fixes one count of
minibatches for all from every module's steps, the fixed seats' included; each learner here
counts instead, over all learners, the rows of the modules it trains, so an iteration takes as
many optimizer steps as one learner takes on the whole batch (rl/config.py splits the batch and
the minibatch); a learner whose shard holds none of those rows steps through as many empty
minibatches, taking the others' gradients (RLlib's own loop would fail on it, and the others
would wait in the all-reduce for ever); a learner whose update fails ends the process group, so
that the others' all-reduce fails at once too and the error reaches the run, where they would
wait for the group's time-out (30 minutes). RLlib shards by slicing episodes, which can leave a
trained agent a slice without a step; `TrainedAgentsOnly` drops those (RLlib's connector fails
on them). A learner actor runs on the CPUs it holds
(`--num-cpus-per-learner`, one thread at least), the learner in the algorithm's process on
`--torch-threads`.

On a GPU (`--num-gpus-per-learner`) RLlib moves every module of the learner to its device, the
weights they started from included; env runners keep theirs on the CPU and get the learner's
weights as numpy. cuDNN and cuBLAS may round float32 convolutions and products to TF32 (a 10-bit
mantissa), which would move pi's log-probabilities against the env runners' float32 ones as
bfloat16 does (rl_module.py), so the learner turns TF32 off.
"""

from __future__ import annotations

import math
import os

import torch
import torch.distributed as dist
from ray.rllib.algorithms.ppo.torch.ppo_torch_learner import PPOTorchLearner
from ray.rllib.core.columns import Columns
from ray.rllib.evaluation.postprocessing import Postprocessing
from ray.rllib.policy.sample_batch import MultiAgentBatch

from ..curriculum.names import LEARNER, LEARNER_THREADS_ENV
from ..game.constants import NUM_ACTIONS
from .teacher import TEACHER_COLUMN, TEACHER_WEIGHT_KEY, teacher_loss
from .trained_agents import TrainedAgentsOnly

DUAL_CLIP_KEY = "dual_clip"  # in the config's learner_config_dict
RARE_LOGP = -10.0  # a sampled log-probability below this is a filter's override (docstring)


def dual_clipped(advantages: torch.Tensor, log_ratio: torch.Tensor, bound: float) -> torch.Tensor:
    """The rows whose advantage PPO's clipped loss must see as 0 to have the dual-clip loss's
    gradient: a negative advantage and a ratio beyond `bound` (module docstring)."""
    return (advantages < 0) & (log_ratio > math.log(bound))


class PommerPPOLearner(PPOTorchLearner):
    """RLlib's PPO torch learner with a fused Adam per module and a connector that batches the
    trained agents only, which refuses to train a learner module whose pi has no weights, skips
    non-finite updates, can dual-clip, and as one of several learner actors averages its
    gradients with theirs (module docstring)."""
    def build(self) -> None:
        # Ray gives the algorithm's process, where the local learner lives (and samples,
        # without remote env runners), one OpenMP thread per CPU it holds (one); `train
        # --torch-threads` says how many it may use. A learner actor uses the CPUs it holds.
        cpus = self.config.num_cpus_per_learner  # RLlib's default is "auto": one
        torch.set_num_threads(max(1, int(cpus) if isinstance(cpus, int | float) else 1)
                              if self.config.num_learners else
                              int(os.environ.get(LEARNER_THREADS_ENV, "1")))
        torch.set_flush_denormal(True)  # the planes are sparse (docs/measurements.md)
        super().build()
        if self._device.type == "cuda":  # pi in float32 (module docstring)
            torch.backends.cuda.matmul.allow_tf32 = False
            torch.backends.cudnn.allow_tf32 = False
        self._learner_connector.prepend(TrainedAgentsOnly(self.should_module_be_updated))
        if self.distributed:
            self._broadcast_weights()

    def _make_modules_ddp_if_necessary(self) -> None:
        """No DDP wrapper: the learners average their gradients themselves (module
        docstring)."""

    def _trained_ids(self) -> list[str]:
        """The modules this learner trains, in one order on every learner."""
        return sorted(filter(self.should_module_be_updated, self.module.keys()))

    def _broadcast_weights(self) -> None:
        """Every torch module's weights and buffers as learner 0 built them, on every learner
        (a vf drawn at random, a tensor of the league's book): DDP's start, without DDP."""
        for module_id in sorted(self.module.keys()):
            module = self.module[module_id]
            if isinstance(module, torch.nn.Module):
                for tensor in module.state_dict().values():
                    dist.broadcast(tensor, src=0)

    def _average_gradients(self) -> None:
        """All-reduce the trained modules' gradients over the learners (module docstring): per
        module, the mean over the learners that computed one; None where none did."""
        groups = [[p for p in self.module[mid].parameters() if p.requires_grad]
                  for mid in self._trained_ids()]
        present = torch.tensor([any(p.grad is not None for p in group) for group in groups],
                               dtype=torch.float32, device=self._device)
        flat = torch.cat([present] + [
            (p.grad if p.grad is not None else torch.zeros_like(p)).reshape(-1)
            for group in groups for p in group])
        dist.all_reduce(flat)
        learners, offset = flat[:len(groups)], len(groups)
        for count, group in zip(learners.tolist(), groups, strict=True):
            for p in group:
                size = p.numel()
                p.grad = (flat[offset:offset + size].view_as(p) / count) if count else None
                offset += size

    def compute_gradients(self, loss_per_module, **kwargs):
        gradients = super().compute_gradients(loss_per_module, **kwargs)
        if not self.distributed:
            return gradients
        self._average_gradients()  # also where this learner had no loss: the others wait
        return {pid: p.grad for pid, p in self._params.items()}

    def _uncompiled_update(self, batch, **kwargs):
        if not self.distributed:
            return super()._uncompiled_update(batch, **kwargs)
        # RLlib's update, less the DDP modules' `no_sync` it enters with N learners; an empty
        # minibatch (`_create_iterator_if_necessary`) only takes the others' gradients
        fwd_out, loss_per_module = {}, {}
        if batch:
            self._compute_off_policyness(batch)
            fwd_out = self.module.forward_train(batch)
            loss_per_module = self.compute_losses(fwd_out=fwd_out, batch=batch)
        gradients = self.compute_gradients(loss_per_module)
        self.apply_gradients(self.postprocess_gradients(gradients))
        return fwd_out, loss_per_module, {}

    def update(self, *args, **kwargs):
        try:
            return super().update(*args, **kwargs)
        except Exception:
            if self.distributed and dist.is_initialized():  # the others fail, not wait for ever
                dist.destroy_process_group()
            raise

    def _create_iterator_if_necessary(self, *, training_data, num_total_minibatches=0,
                                      num_epochs=1, minibatch_size=None, **kwargs):
        batches = super()._create_iterator_if_necessary(
            training_data=training_data, num_total_minibatches=num_total_minibatches,
            num_epochs=num_epochs, minibatch_size=minibatch_size, **kwargs)
        if not (self.distributed and minibatch_size):
            return batches
        # Every learner takes as many minibatches: one learner's count for the trained rows of
        # all (module docstring). RLlib's iterator keeps its count in `_num_total_minibatches`.
        local = getattr(batches, "_batch", None)  # None: no rows of a trained module here
        rows = torch.tensor([len(local.policy_batches.get(mid, ())) if local is not None else 0
                             for mid in self._trained_ids()], dtype=torch.int64,
                            device=self._device)
        dist.all_reduce(rows)
        count = max(1, math.ceil(
            num_epochs * int(rows.max()) / (self.config.num_learners * minibatch_size)))
        if local is None:  # still one all-reduce per minibatch, or the others wait for ever
            return [MultiAgentBatch({}, env_steps=0) for _ in range(count)]
        batches._num_total_minibatches = count
        return batches

    def configure_optimizers_for_module(self, module_id, config=None) -> None:
        params = self.get_parameters(self._module[module_id])
        self.register_optimizer(module_id=module_id,
                                optimizer=torch.optim.Adam(params, fused=True), params=params,
                                lr_or_lr_schedule=config.lr)

    def compute_loss_for_module(self, *, module_id, config, batch, fwd_out):
        teacher_rows = None
        if self.should_module_be_updated(module_id):  # the learner, and an exploiter (league.py)
            logits = fwd_out[Columns.ACTION_DIST_INPUTS].detach()
            module = self.module[module_id].unwrapped()
            dist = module.get_train_action_dist_cls().from_logits(logits)
            log_ratio = dist.logp(batch[Columns.ACTIONS]) - batch[Columns.ACTION_LOGP]  # PPO's
            valid = (batch[Columns.LOSS_MASK].bool() if Columns.LOSS_MASK in batch
                     else torch.ones_like(log_ratio, dtype=torch.bool))
            self._log_pi_health(module_id, logits[..., :NUM_ACTIONS],  # the moves' (not words')
                                log_ratio[valid], batch[Columns.ACTION_LOGP][valid])
            bound = config.learner_config_dict.get(DUAL_CLIP_KEY, math.inf)
            if bound < math.inf:
                advantages = batch[Postprocessing.ADVANTAGES]
                clipped = dual_clipped(advantages, log_ratio, bound) & valid
                self.metrics.log_value((module_id, "pi_dual_clipped_rows"), int(clipped.sum()),
                                       reduce="sum")
                batch = {**batch, Postprocessing.ADVANTAGES: advantages.masked_fill(clipped, 0)}
            teacher_rows = valid & (log_ratio.abs() <= math.log1p(config.clip_param))
        loss = super().compute_loss_for_module(module_id=module_id, config=config, batch=batch,
                                               fwd_out=fwd_out)
        weight = config.learner_config_dict.get(TEACHER_WEIGHT_KEY, 0.0)
        if weight and module_id == LEARNER and TEACHER_COLUMN in batch:  # teacher.py
            xent, agreement = teacher_loss(fwd_out[Columns.ACTION_DIST_INPUTS],
                                           batch[TEACHER_COLUMN], teacher_rows)
            self.metrics.log_value((module_id, "teacher_xent"), xent.item(), window=100)
            self.metrics.log_value((module_id, "teacher_agreement"), agreement.item(),
                                   window=100)
            loss = loss + weight * xent
        return loss

    def _log_pi_health(self, module_id: str, logits: torch.Tensor, log_ratio: torch.Tensor,
                       sampled_logp: torch.Tensor) -> None:
        """Per iteration: the largest batch-mean logit spread, and the extremes of PPO's log-ratio
        (log pi(a) now minus when sampled) over the rows it trains on, all and rare (module
        docstring): a log-ratio above 88 overflows PPO's float32 ratio to inf, whose backward is
        nan even where the clip or the min leaves that row's gradient at zero."""
        spread = (logits.max(-1).values - logits.min(-1).values).mean()
        self.metrics.log_value((module_id, "pi_logit_spread"), spread.item(), reduce="max")
        rare = sampled_logp < RARE_LOGP
        self.metrics.log_value((module_id, "pi_rare_rows"), int(rare.sum()), reduce="sum")
        for prefix, rows in (("pi_log_ratio", log_ratio), ("pi_rare_log_ratio", log_ratio[rare])):
            if rows.numel():
                self.metrics.log_value((module_id, f"{prefix}_max"), rows.max().item(),
                                       reduce="max")
                self.metrics.log_value((module_id, f"{prefix}_min"), rows.min().item(),
                                       reduce="min")

    def apply_gradients(self, gradients_dict) -> None:
        finite = all(grad is None or torch.isfinite(grad).all()
                     for grad in gradients_dict.values())
        if self._learner_index == 0:  # every learner skips the same updates: count them once
            self.metrics.log_value((LEARNER, "nonfinite_updates_skipped"), int(not finite),
                                   reduce="sum")
        if finite:  # else no step: the next minibatch's backward starts from zeroed gradients
            super().apply_gradients(gradients_dict)

    def before_gradient_based_update(self, *, timesteps) -> None:
        super().before_gradient_based_update(timesteps=timesteps)
        for module_id, module in self.module.items():
            if self.should_module_be_updated(module_id):
                module.unwrapped().require_pi()
