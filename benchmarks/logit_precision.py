"""How far pi's log-probabilities move under bfloat16 autocast, against float32, per policy:

    python benchmarks/logit_precision.py policies/ppo_cautious/pi.pt campaign/paper

Observations: 4 seeded games of the team env with random actions (410 observations). For each
weights file (`pi.pt`) or run / checkpoint folder, over all actions and over those below
log-probability -10 (the rare actions a filter override puts into PPO's batch, whose ratio the
clip of 0.01 is meant to bound):
- `|logp bf16 - fp32|`: the rounding error of bfloat16 itself;
- `one step`: |logp after - logp before| when every weight moves by 1e-4 (the size of an Adam
  step at lr 1e-4, signs drawn with seed 0), computed in float32, in bfloat16, and with only the
  convolutions in bfloat16 (`trunk bf16`: the head, and so the logits, in float32; the
  convolutions are most of pi's FLOPs): the log-ratio one update gives PPO, real change plus, in
  bfloat16, the rounding that the step flips;
- the largest |logp| difference between float32 batches of 1 to 128 rows and all rows at once
  (the env runners' batches against the learner's).
Not part of CI; figures in rl/rl_module.py.
"""

from __future__ import annotations

import copy
import sys

import numpy as np
import torch

from rllib_pommer.imitation.learned import load_policy_net
from rllib_pommer.rl.env import PommeEnv
from rllib_pommer.runs.checkpoints import load_checkpoint_net

RARE_LOGP = -10.0
ADAM_STEP = 1e-4


def observations(games: int = 4, steps: int = 300) -> torch.Tensor:
    """The planes every agent saw in `games` seeded games of random play."""
    planes = []
    for seed in range(games):
        env, rng = PommeEnv({"seed": seed}), np.random.default_rng(seed)
        obs, _ = env.reset(seed=seed)
        for _ in range(steps):
            planes += [o["planes"] for o in obs.values()]
            obs, _, terminated, _, _ = env.step({a: int(rng.integers(6)) for a in obs})
            if terminated["__all__"]:
                break
    return torch.as_tensor(np.stack(planes)).contiguous(memory_format=torch.channels_last)


PRECISIONS = ("fp32", "bf16", "trunk bf16")


def log_probs(net: torch.nn.Module, x: torch.Tensor, precision: str = "fp32") -> torch.Tensor:
    """pi's log-probabilities with everything in float32, everything under bfloat16 autocast,
    or only the convolutions (`net.convs`) under it."""
    with torch.no_grad():
        with torch.autocast("cpu", dtype=torch.bfloat16, enabled=precision != "fp32"):
            hidden = net.convs(x)
        with torch.autocast("cpu", dtype=torch.bfloat16, enabled=precision == "bf16"):
            logits = net.head(hidden.float() if precision == "trunk bf16" else hidden)
        return torch.log_softmax(logits.float(), -1)


def stepped(net: torch.nn.Module) -> torch.nn.Module:
    """`net` with every weight moved by +-ADAM_STEP."""
    moved, generator = copy.deepcopy(net), torch.Generator().manual_seed(0)
    with torch.no_grad():
        for parameter in moved.parameters():
            parameter.add_(ADAM_STEP * torch.randn(parameter.shape, generator=generator).sign())
    return moved


def batch_size_error(net: torch.nn.Module, x: torch.Tensor) -> float:
    whole = log_probs(net, x)
    return max((torch.cat([log_probs(net, x[i:i + size])
                           for i in range(0, len(x), size)]) - whole).abs().max().item()
               for size in (1, 2, 3, 8, 33, 128))


def summary(error: torch.Tensor, rare: torch.Tensor) -> str:
    text = f"median {error.median():.4f}, p99 {error.quantile(0.99):.3f}"
    if rare.any():
        text += (f"; rare: median {error[rare].median():.4f}, p99 "
                 f"{error[rare].quantile(0.99):.3f}, max {error[rare].max():.3f}")
    return text


def main(sources: list[str]) -> None:
    torch.set_num_threads(1)
    x = observations()
    for source in sources:
        net = load_policy_net(source) if source.endswith(".pt") else load_checkpoint_net(source)
        net = net.to(memory_format=torch.channels_last)
        moved = stepped(net)
        full, half = log_probs(net, x), log_probs(net, x, "bf16")
        rare = full < RARE_LOGP
        with torch.no_grad():
            logits = net(x)
        spread = logits.max(-1).values - logits.min(-1).values
        print(f"{source}: {len(x)} observations, logit spread median {spread.median():.1f} max "
              f"{spread.max():.1f}, share of actions below logp {RARE_LOGP:g}: "
              f"{rare.float().mean():.3f}")
        print(f"  |logp bf16 - fp32|: {summary((half - full).abs(), rare)}")
        for precision in PRECISIONS:
            change = (log_probs(moved, x, precision) - log_probs(net, x, precision)).abs()
            print(f"  one step, {precision}: {summary(change, rare)}")
        print(f"  fp32 batch sizes 1-128 against all rows: max |logp| difference "
              f"{batch_size_error(net, x):.1e}")


if __name__ == "__main__":
    main(sys.argv[1:])
