"""The paper's policy CNN, one `nn.Module` for behaviour cloning, the PPO policy and its value net.

    input (19, 11, 11)
    conv 3x3, 19 -> 32, ReLU, max-pool 2 (ceil: 11 -> 6), dropout
    conv 3x3, 32 -> 64, ReLU, max-pool 2 (6 -> 3), dropout
    conv 3x3, 64 -> 64, ReLU, max-pool 2 (3 -> 2), dropout
    flatten 64 * 2 * 2 = 256 -> FC 128, ReLU -> FC num_outputs (6 logits, or 1 value)

About 94k parameters (0.4 MB as float32). Dropout is used in behaviour cloning only; with
`dropout=0` its layers are identities, and since dropout has no parameters the same state_dict
loads into either build (the PPO module's pi and its separate vf replica).
"""

from __future__ import annotations

import torch
from torch import nn

from ..game.constants import NUM_ACTIONS
from .features import NUM_PLANES

CHANNELS = (32, 64, 64)
HIDDEN = 128


class PommerNet(nn.Module):
    """The paper's CNN (module docstring): 19 planes in, `num_outputs` logits or one value out."""
    def __init__(self, num_outputs: int = NUM_ACTIONS, dropout: float = 0.0):
        super().__init__()
        layers: list[nn.Module] = []
        in_channels = NUM_PLANES
        for out_channels in CHANNELS:
            layers += [
                nn.Conv2d(in_channels, out_channels, kernel_size=3, padding=1),
                nn.ReLU(),
                nn.MaxPool2d(2, ceil_mode=True),
                nn.Dropout(dropout) if dropout > 0 else nn.Identity(),
            ]
            in_channels = out_channels
        self.convs = nn.Sequential(*layers)
        self.head = nn.Sequential(
            nn.Flatten(),
            nn.Linear(CHANNELS[-1] * 2 * 2, HIDDEN),
            nn.ReLU(),
            nn.Linear(HIDDEN, num_outputs),
        )

    def forward(self, planes: torch.Tensor) -> torch.Tensor:
        """(B, 19, 11, 11) float planes -> (B, num_outputs)."""
        return self.head(self.convs(planes))
