"""The learner measures behind `bench learn`: FLOPs counted right, every measure runs."""

from __future__ import annotations

import torch

from rllib_pommer.curriculum.settings import PPOSettings
from rllib_pommer.imitation import speed
from rllib_pommer.imitation.network import PommerNet


def _forward_macs(num_outputs: int) -> int:
    """Multiply-adds of one sample, from the layer shapes: conv outputs on 11x11, 6x6 and 3x3
    cells (pooling halves, rounding up), then the two fully connected layers."""
    net = PommerNet(num_outputs)
    convs = [m for m in net.modules() if isinstance(m, torch.nn.Conv2d)]
    linears = [m for m in net.modules() if isinstance(m, torch.nn.Linear)]
    cells = (11 * 11, 6 * 6, 3 * 3)
    return (sum(c * conv.out_channels * conv.in_channels * 9 for c, conv in zip(cells, convs,
                                                                                 strict=True))
            + sum(fc.in_features * fc.out_features for fc in linears))


def test_flops_are_two_per_multiply_add_and_backward_costs_about_twice_forward():
    for outputs in (6, 1):
        forward = speed.flops_per_sample(outputs, backward=False)
        assert forward == 2 * _forward_macs(outputs)
        total = speed.flops_per_sample(outputs)
        first_conv_input_grad = 2 * 11 * 11 * 32 * 19 * 9  # not needed: the planes are data
        assert total == 3 * forward - first_conv_input_grad


def test_every_measure_runs_and_reports_a_rate():
    assert speed.plain_ppo_samples_per_s(PPOSettings(), seconds=0.1) > 0
    speeds = speed.bc_speeds(seconds=0.1)
    assert speeds["bc_samples_per_s"] > 0 and speeds["bc_baseline_samples_per_s"] > 0
    bound = speed.flop_bound(seconds=0.1)
    assert bound["flop_bound_samples_per_s"] == (bound["peak_flops_assumed"]
                                                 / bound["ppo_flops_per_sample"])
