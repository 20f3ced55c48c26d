"""How fast the networks learn on this CPU: baselines, the real behaviour-cloning step and a bound.

The measures behind `python -m rllib_pommer.bench learn` that need torch but not Ray:

* `plain_ppo_samples_per_s`: PPO's update as plain eager float32 NCHW torch, the network as it
  stood before any speed work: pi and a separate vf (`PommerNet`), a clipped surrogate plus value
  loss, Adam, gradient clip, with the minibatch, clip, lr and gradient clip it is given (the
  caller, `launch/speed.py`, gives the real learner's `PPOSettings`). The baseline the RLlib learner
  is compared to.
* `bc_samples_per_s`: the real behaviour-cloning step (`bc.train_step` with `BCConfig`'s speed
  settings), beside `plain_bc_samples_per_s`, the same step with those settings off.
* `flop_bound`: FLOPs per trained sample counted by torch's `FlopCounterMode` (forward and
  backward), and this core's float32 peak measured with a large matrix product: the samples/s no
  implementation of the same arithmetic in float32 could beat.

Inputs are sparse binary planes (10% ones, as real boards are mostly one-hot), so denormal
flushing and memory traffic behave as in training. All figures are for the current torch thread
count; the caller sets it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

import numpy as np
import torch
from torch.nn import functional as F
from torch.utils.flop_counter import FlopCounterMode

from ..data.schema import Batch
from ..game.constants import BOARD_SIZE, NUM_ACTIONS
from ..game.observation import empty_observations
from .bc import BCConfig, build_net, train_step
from .features import NUM_PLANES
from .network import PommerNet

BC_BATCH = 512
COUNTED_ROWS = 16  # a batch to count FLOPs on: per sample, they do not depend on its size


class PPOUpdate(Protocol):
    """The PPO settings the baseline update uses (`curriculum/settings.PPOSettings` has them)."""

    minibatch_size: int
    clip_param: float
    lr: float
    grad_clip: float


def sparse_planes(rows: int, seed: int = 0) -> torch.Tensor:
    generator = torch.Generator().manual_seed(seed)
    return (torch.rand(rows, NUM_PLANES, BOARD_SIZE, BOARD_SIZE, generator=generator) < 0.1).float()


def _rate(step: Callable[[], int], seconds: float, warmup: int = 3) -> float:
    """Samples/s of repeated `step()` calls (each returns the samples it trained) for about
    `seconds` after `warmup` untimed calls."""
    for _ in range(warmup):
        step()
    samples, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        samples += step()
    return samples / (time.perf_counter() - start)


def _ppo_minibatch_step(pi: PommerNet, vf: PommerNet, optimizer: torch.optim.Optimizer,
                        planes: torch.Tensor, ppo: PPOUpdate) -> int:
    """PPO's loss on one minibatch: clipped surrogate plus squared value error."""
    rows = len(planes)
    actions = torch.randint(0, NUM_ACTIONS, (rows,))
    old_logp, advantages, targets = torch.zeros(rows) - 1.8, torch.randn(rows), torch.randn(rows)
    logp = torch.log_softmax(pi(planes), -1).gather(1, actions[:, None]).squeeze(1)
    ratio = torch.exp(logp - old_logp)
    clipped = ratio.clamp(1 - ppo.clip_param, 1 + ppo.clip_param)
    surrogate = torch.min(ratio * advantages, clipped * advantages)
    loss = -surrogate.mean() + F.mse_loss(vf(planes).squeeze(-1), targets)
    optimizer.zero_grad()
    loss.backward()
    torch.nn.utils.clip_grad_norm_([*pi.parameters(), *vf.parameters()], ppo.grad_clip)
    optimizer.step()
    return rows


def plain_ppo_samples_per_s(ppo: PPOUpdate, seconds: float = 5.0) -> float:
    pi, vf = PommerNet(), PommerNet(num_outputs=1)
    optimizer = torch.optim.Adam([*pi.parameters(), *vf.parameters()], lr=ppo.lr)
    rows = ppo.minibatch_size
    pool = sparse_planes(16 * rows)
    offsets = iter(range(10**9))

    def step() -> int:
        start = next(offsets) % 16 * rows
        return _ppo_minibatch_step(pi, vf, optimizer, pool[start:start + rows], ppo)

    return _rate(step, seconds)


def _bc_batch(rows: int, seed: int = 0) -> Batch:
    """A batch of random board observations (the featurizer's work is part of the step)."""
    rng = np.random.default_rng(seed)
    obs = empty_observations(rows // 4 + 1).agent_rows().select(slice(0, rows))
    obs.board[:] = rng.choice([0, 0, 0, 1, 2, 5], size=obs.board.shape)
    obs.position[:] = rng.integers(0, BOARD_SIZE, size=obs.position.shape)
    obs.game_type[:] = 2
    counts = rng.multinomial(16, [0.3, 0.2, 0.2, 0.1, 0.1, 0.1], size=rows).astype(np.uint8)
    return Batch(obs, rng.integers(0, NUM_ACTIONS, rows), counts)


def bc_samples_per_s(cfg: BCConfig, seconds: float = 5.0) -> float:
    net = build_net(cfg)
    optimizer = torch.optim.Adam(net.parameters(), lr=cfg.lr)
    batch = _bc_batch(cfg.batch_size)

    def step() -> int:
        train_step(net, optimizer, batch, cfg)
        return cfg.batch_size

    return _rate(step, seconds)


def bc_speeds(seconds: float = 5.0) -> dict:
    """The real BC step (BCConfig's defaults) beside its plain float32 NCHW form."""
    real = BCConfig(data=Path("."), out=Path("."), batch_size=BC_BATCH)
    plain = BCConfig(data=Path("."), out=Path("."), batch_size=BC_BATCH, channels_last=False,
                     bf16=False)
    return {"bc_samples_per_s": bc_samples_per_s(real, seconds),
            "bc_baseline_samples_per_s": bc_samples_per_s(plain, seconds)}


def flops_per_sample(num_outputs: int = NUM_ACTIONS, backward: bool = True) -> int:
    """FLOPs of one sample through `PommerNet` (forward, plus backward if asked), as torch's
    `FlopCounterMode` counts them."""
    net = PommerNet(num_outputs=num_outputs)
    planes = sparse_planes(COUNTED_ROWS)
    with FlopCounterMode(display=False) as counter:
        out = net(planes).sum()
        if backward:
            out.backward()
    return counter.get_total_flops() // COUNTED_ROWS


def float32_peak_flops(seconds: float = 2.0, size: int = 1024) -> float:
    """This core's float32 FLOP/s on a large matrix product (the best case for any kernel)."""
    a, b = torch.randn(size, size), torch.randn(size, size)
    flops_per_product = 2 * size**3
    return _rate(lambda: torch.mm(a, b) is not None and flops_per_product, seconds)


def flop_bound(seconds: float = 2.0) -> dict:
    """FLOPs per PPO sample (pi and vf trained, vf once more for the advantages) and the
    samples/s this core's float32 peak allows."""
    per_sample = flops_per_sample() + flops_per_sample(1) + flops_per_sample(1, backward=False)
    peak = float32_peak_flops(seconds)
    return {"ppo_flops_per_sample": per_sample, "peak_flops_assumed": peak,
            "flop_bound_samples_per_s": peak / per_sample}
