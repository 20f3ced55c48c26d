"""The paper's policy CNN, one `nn.Module` for behaviour cloning, the PPO policy and its value net.

    input (19, 11, 11)
    conv 3x3, 19 -> 32, ReLU, max-pool 2 (ceil: 11 -> 6), dropout
    conv 3x3, 32 -> 64, ReLU, max-pool 2 (6 -> 3), dropout
    conv 3x3, 64 -> 64, ReLU, max-pool 2 (3 -> 2), dropout
    flatten 64 * 2 * 2 = 256 -> FC 128, ReLU -> FC num_outputs (6 logits, or 1 value)

About 94k parameters (0.4 MB as float32). Dropout is used in behaviour cloning only; with
`dropout=0` its layers are identities, and since dropout has no parameters the same state_dict
loads into either build (the PPO module's pi and its separate vf replica).

`RadioNet` is the same network for TeamRadio (docs/rules.md §10): it hears the teammate's two
words (one-hot 2 x 8, `features.message_features`), added through a linear map into the FC 128
layer before its ReLU (a concatenation of the words after the conv trunk, written as a sum), and
with `words` it speaks too: two 8-way word heads on the same 128 features beside the move logits.

    out = [moves (num_outputs) | word 1 (8) | word 2 (8)]

Both new maps start at zero, so a `RadioNet` holding a Team net's weights (`load_team_state`)
gives that net's move logits exactly, whatever it hears, and uniform words; training moves them
from there. `PommerNet` itself is unchanged (its state_dict keys and shapes), so every shipped
Team policy keeps loading, into either class.
"""

from __future__ import annotations

import torch
from torch import nn

from ..game.constants import NUM_ACTIONS, RADIO_NUM_WORDS, RADIO_VOCAB_SIZE
from .features import NUM_PLANES

CHANNELS = (32, 64, 64)
HIDDEN = 128
WORD_LOGITS = RADIO_NUM_WORDS * RADIO_VOCAB_SIZE  # the two word heads, and the one-hot message


class PommerNet(nn.Module):
    """The paper's CNN (module docstring): 19 planes in (22 with memory, `planes`),
    `num_outputs` logits or one value out."""
    def __init__(self, num_outputs: int = NUM_ACTIONS, dropout: float = 0.0,
                 planes: int = NUM_PLANES):
        super().__init__()
        self.planes = planes
        layers: list[nn.Module] = []
        in_channels = planes
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
        return self.head(self.convs(self.first_planes(planes)))

    def first_planes(self, planes: torch.Tensor) -> torch.Tensor:
        """The planes this net reads, the first `self.planes` of its input: a 19-plane net plays
        in an env that also draws the memory planes (`recall.py`), which follow the 19."""
        if planes.shape[1] == self.planes:
            return planes
        if planes.shape[1] < self.planes:
            raise ValueError(f"this network reads {self.planes} input planes (with memory: "
                             f"imitation/recall.py) but was given {planes.shape[1]}; a policy "
                             f"with memory plays only where the planes include it (a "
                             f"curriculum's `memory = true`)")
        return planes[:, :self.planes]


class RadioNet(PommerNet):
    """PommerNet that hears its teammate's words and, with `words`, speaks two (module
    docstring): (planes, message) in, [num_outputs | 8 | 8] logits out (num_outputs alone
    without `words`: the value net)."""
    RADIO_KEYS = ("hear.weight", "speak.weight", "speak.bias")

    def __init__(self, num_outputs: int = NUM_ACTIONS, words: bool = True, dropout: float = 0.0,
                 planes: int = NUM_PLANES):
        super().__init__(num_outputs, dropout, planes)
        self.hear = nn.Linear(WORD_LOGITS, HIDDEN, bias=False)
        nn.init.zeros_(self.hear.weight)
        self.speak = nn.Linear(HIDDEN, WORD_LOGITS) if words else None
        if self.speak is not None:
            nn.init.zeros_(self.speak.weight)
            nn.init.zeros_(self.speak.bias)

    def forward(self, planes: torch.Tensor, message: torch.Tensor) -> torch.Tensor:
        """(B, 19, 11, 11) float planes and (B, 2, 8) one-hot words -> (B, num_outputs [+ 16])."""
        flatten, hidden, relu, out = self.head
        features = relu(hidden(flatten(self.convs(self.first_planes(planes))))
                        + self.hear(message.flatten(1)))
        if self.speak is None:
            return out(features)
        return torch.cat([out(features), self.speak(features)], dim=-1)

    def load_team_state(self, state: dict) -> None:
        """Load a Team `PommerNet`'s state_dict (its keys and shapes exactly, else torch's
        error); hearing and speaking keep their weights (zero when new, module docstring)."""
        own = self.state_dict()
        self.load_state_dict({**widened(state, self.planes),
                              **{key: own[key] for key in self.RADIO_KEYS if key in own}})


def is_radio_state(state: dict) -> bool:
    """Whether a state_dict is a `RadioNet`'s (it hears), not a Team `PommerNet`'s."""
    return "hear.weight" in state


FIRST_CONV = "convs.0.weight"


def planes_of(state: dict) -> int:
    """How many input planes a state_dict's network reads: 19, or 22 with memory. A state whose
    first convolution is no 4-D kernel reads as 19, and loading it names the misfit."""
    kernel = state.get(FIRST_CONV)
    return int(kernel.shape[1]) if getattr(kernel, "ndim", 0) == 4 else NUM_PLANES


def widened(state: dict, planes: int) -> dict:
    """`state` for a net reading `planes` inputs: a net reading fewer gets zero weights on the
    planes it did not read, so the wider net computes exactly what it did (the memory planes of
    recall.py start unheard, as a RadioNet's words do); a net reading more is refused."""
    have = planes_of(state)
    if have == planes or FIRST_CONV not in state:
        return state
    if have > planes:
        raise ValueError(f"weights read {have} input planes, more than this network's {planes}: "
                         f"a policy with memory (imitation/recall.py) cannot play without it")
    weight = state[FIRST_CONV]
    pad = weight.new_zeros((weight.shape[0], planes - have, *weight.shape[2:]))
    return {**state, FIRST_CONV: torch.cat([weight, pad], dim=1)}


def build_net(num_outputs: int = NUM_ACTIONS, radio: bool = False,
              planes: int = NUM_PLANES) -> PommerNet:
    """A policy (`num_outputs` 6) or value (1) network of the Team game, or with `radio` of
    TeamRadio, whose policy speaks (`RadioNet`), reading `planes` inputs; dropout off."""
    return RadioNet(num_outputs, words=num_outputs == NUM_ACTIONS, planes=planes) if radio \
        else PommerNet(num_outputs, planes=planes)


def load_weights(net: PommerNet, state: dict) -> None:
    """`state` into `net`: a `RadioNet` takes a radio state_dict as is and a Team one through
    `load_team_state`, a `PommerNet` a Team one; weights of a net reading fewer planes are
    `widened`; anything else is torch's error naming the keys or shapes that do not fit."""
    if isinstance(net, RadioNet) and not is_radio_state(state):
        net.load_team_state(state)
    else:
        net.load_state_dict(widened(state, net.planes))
