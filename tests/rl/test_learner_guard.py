"""The learner skips an update whose gradients are not finite, so Adam's moments stay finite
(RLlib's default steps with inf replaced by the largest float, which makes them inf for good),
and its dual clip gives PPO's loss the dual-clip loss's gradient."""

from __future__ import annotations

import dataclasses

import torch

from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.names import LEARNER
from rllib_pommer.rl.config import build_config
from rllib_pommer.rl.learner import dual_clipped

CLIP = 0.01


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


def _ppo_surrogate(ratio, advantages):  # as RLlib's PPO loss computes it
    return torch.min(advantages * ratio, advantages * ratio.clamp(1 - CLIP, 1 + CLIP))


def test_zeroing_the_dual_clipped_advantages_gives_the_dual_clip_gradient():
    """max(min(rA, clip(r)A), cA) for A < 0 (Ye et al. 2020) against PPO's surrogate with the
    advantages of the rows `dual_clipped` names set to 0: the same gradient on every row, and
    rows with a negative advantage and a ratio beyond c have none."""
    generator = torch.Generator().manual_seed(0)
    advantages = torch.randn(4000, generator=generator)
    log_ratio = (torch.randn(4000, generator=generator) * 2).requires_grad_()
    bound = 3.0

    ratio = log_ratio.exp()
    dual = _ppo_surrogate(ratio, advantages)
    dual = torch.where(advantages < 0, torch.max(dual, bound * advantages), dual)
    expected, = torch.autograd.grad(dual.sum(), log_ratio)
    masked = advantages.masked_fill(dual_clipped(advantages, log_ratio.detach(), bound), 0)
    got, = torch.autograd.grad(_ppo_surrogate(log_ratio.exp(), masked).sum(), log_ratio)

    torch.testing.assert_close(got, expected)
    beyond = (advantages < 0) & (log_ratio.detach().exp() > bound)
    assert 100 < beyond.sum() < 4000 and (got[beyond] == 0).all()
    ordinary, = torch.autograd.grad(_ppo_surrogate(log_ratio.exp(), advantages).sum(), log_ratio)
    assert (ordinary[beyond] != 0).all()  # what the dual clip takes away


def test_a_curriculum_with_a_dual_clip_clips_rows_once_pi_trains(ray_session, pi_weights):
    """The smoke curriculum with a bound just above 1: no row during the warm-up (pi frozen, so
    every ratio is 1 up to float32 rounding), some once pi moves."""
    smoke = load_curriculum("smoke")
    curriculum = dataclasses.replace(smoke, ppo=dataclasses.replace(smoke.ppo, dual_clip=1.001))
    algo = build_config(curriculum, pi_weights=pi_weights).build_algo()
    try:
        clipped, stage = [0, 0], 0  # per stage: rows clipped
        while True:
            result = algo.train()
            health = result["learners"][LEARNER]
            clipped[stage] += health["pi_dual_clipped_rows"]
            assert "pi_rare_rows" in health  # logged on every iteration, 0 or more
            stage = result["curriculum"]["stage"]
            if result["curriculum"]["episodes"] >= curriculum.total_episodes:
                break
        assert clipped[0] == 0 and clipped[1] > 0
    finally:
        algo.stop()
