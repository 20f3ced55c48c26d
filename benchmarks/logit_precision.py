"""How far pi's log-probabilities move under bfloat16 autocast, against float32, per policy:

    python benchmarks/logit_precision.py policies/ppo_cautious/pi.pt campaign/team

Observations: 4 seeded games of the team env with random actions (410 observations). For each
weights file (`pi.pt`) or run / checkpoint folder: pi's logit spread, and |logp bf16 - logp fp32|
over all actions and over those below log-probability -10, the rare actions a filter override
puts into PPO's batch (whose ratio the clip of 0.01 is meant to bound). Not part of CI.
"""

from __future__ import annotations

import sys

import numpy as np
import torch

from rllib_pommer.imitation.learned import load_policy_net
from rllib_pommer.rl.checkpoint_policy import load_checkpoint_net
from rllib_pommer.rl.env import PommeEnv

RARE_LOGP = -10.0


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


def main(sources: list[str]) -> None:
    torch.set_num_threads(1)
    x = observations()
    for source in sources:
        net = load_policy_net(source) if source.endswith(".pt") else load_checkpoint_net(source)
        net = net.to(memory_format=torch.channels_last)
        with torch.no_grad():
            full = net(x).float()
            with torch.autocast("cpu", dtype=torch.bfloat16):
                half = net(x).float()
        logp_full, logp_half = torch.log_softmax(full, -1), torch.log_softmax(half, -1)
        spread = full.max(-1).values - full.min(-1).values
        error = (logp_half - logp_full).abs()
        rare = error[logp_full < RARE_LOGP]
        rare_text = (f"median {rare.median():.3f}, max {rare.max():.2f}, share of actions "
                     f"{rare.numel() / error.numel():.3f}" if rare.numel() else "none")
        print(f"{source}: {len(x)} observations; logit spread median {spread.median():.1f}, max "
              f"{spread.max():.1f}; |logp bf16 - fp32| median {error.median():.3f}; on actions "
              f"below logp {RARE_LOGP:g}: {rare_text}")


if __name__ == "__main__":
    main(sys.argv[1:])
