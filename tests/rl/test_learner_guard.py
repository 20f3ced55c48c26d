"""The learner skips an update whose gradients are not finite, so Adam's moments stay finite
(RLlib's default steps with inf replaced by the largest float, which makes them inf for good)."""

from __future__ import annotations

import torch

from rllib_pommer.rl.config import build_config
from rllib_pommer.rl.curriculum import load_curriculum
from rllib_pommer.rl.rl_module import LEARNER


def _adam_moments(learner) -> list[torch.Tensor]:
    return [state[key].clone() for _, optimizer in learner.get_optimizers_for_module(LEARNER)
            for state in optimizer.state.values() for key in ("exp_avg", "exp_avg_sq")]


def test_a_nonfinite_gradient_skips_the_update_and_keeps_adam_finite(ray_session, pi_weights):
    algo = build_config(load_curriculum("smoke"), pi_weights=pi_weights).build_algo()
    try:
        learner = algo.learner_group._learner
        params = {pid: p for pid, p in learner._params.items() if p.requires_grad}
        learner.apply_gradients({pid: torch.full_like(p, 1e-3) for pid, p in params.items()})
        before = {pid: p.detach().clone() for pid, p in params.items()}
        moments = _adam_moments(learner)
        assert moments and all(torch.isfinite(m).all() for m in moments)

        poisoned = {pid: torch.full_like(p, 1e-3) for pid, p in params.items()}
        next(g for g in poisoned.values() if g.dim() == 1)[0] = float("inf")  # one bias
        learner.apply_gradients(poisoned)

        assert all(torch.equal(before[pid], p) for pid, p in params.items())
        after = _adam_moments(learner)
        assert all(torch.equal(a, b) for a, b in zip(moments, after, strict=True))
        assert learner.metrics.peek((LEARNER, "nonfinite_updates_skipped")) == 1

        learner.apply_gradients({pid: torch.full_like(p, 1e-3) for pid, p in params.items()})
        assert any(not torch.equal(before[pid], p) for pid, p in params.items())
    finally:
        algo.stop()
