"""Learned policies: a `PommerNet` state_dict named by a policy file, played as an Agent.

A policy file of kind "learned" names its weights (`weights = "imitation/pi.pt"`, relative to the
file) and how to act (`greedy = false` samples from the softmax with the agent's own random
stream, as PPO's stochastic policy does; `true` takes the most likely action). Weights load with
`torch.load(weights_only=True)`: plain tensors only, no arbitrary pickle.

Both kinds of learned policy are played here: "learned" (a state_dict file) and, registered by
`rl/checkpoint_policy.py`, "rllib_checkpoint" (a PPO run's learner). Each kind registers the key
naming its path and the loader of its network (`register_learned_kind`); the path is resolved
against the policy file (`PolicySpec.file`), and one network is loaded per (kind, path, greedy)
(and the file's other keys, such as a checkpoint's `module`) in a process, whichever kind.

Many agents of one policy can share one forward pass: `prefetch` computes the actions of a batch
of agents from their observations and parks each one on its agent, whose next `act` returns it.
The arena uses this to batch inference across the games a worker plays in lockstep; wrappers
(action filter, jitter correction) still call `act` as usual.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import torch

from ..agents.base import innermost
from ..agents.registry import (
    PolicySpec,
    make_agent,
    register_kind,
    registered,
    resolve_policy,
)
from ..game.constants import NUM_ACTIONS, RADIO_NUM_WORDS
from ..game.observation import Observation
from .features import featurize, message_features
from .network import PommerNet, RadioNet, build_net, is_radio_state, load_weights


def load_policy_net(path: str | Path, num_outputs: int = NUM_ACTIONS,
                    radio: bool | None = None) -> PommerNet:
    """A policy network (dropout off, eval mode) from a state_dict file, with a clear error;
    `num_outputs=1` reads a PPO value network. It is a `RadioNet` for a TeamRadio state_dict,
    a `PommerNet` for a Team one; `radio=True` asks for a `RadioNet` from either (a Team net's
    move logits exactly: `network.load_weights`), `radio=False` for a `PommerNet`."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: weights file not found")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises several types for corrupt or foreign files
        raise ValueError(f"{path}: not a readable weights file ({exc})") from None
    net = build_net(num_outputs, is_radio_state(state) if radio is None else radio)
    try:
        load_weights(net, state)
    except (RuntimeError, TypeError, AttributeError) as exc:
        raise ValueError(f"{path}: weights do not fit {type(net).__name__} ({exc})") from None
    return net.eval()


class LearnedPolicy:
    """One network shared by every agent of a policy in this process; `source` is the file its
    weights were read from (a state_dict, or a checkpoint's module state)."""

    def __init__(self, net: PommerNet, greedy: bool, source: Path):
        self.net = net
        self.greedy = greedy
        self.source = source

    @torch.no_grad()
    def probabilities(self, obs: Observation) -> np.ndarray:
        """Action probabilities (B, 6) for observations with leading shape (B,). A TeamRadio
        network (`RadioNet`) plays its moves alone here, hearing silence: the Agent protocol
        hands agents no message and takes no words from them."""
        planes = torch.from_numpy(featurize(obs))
        if isinstance(self.net, RadioNet):
            silence = message_features(np.zeros((len(planes), RADIO_NUM_WORDS), np.int64))
            logits = self.net(planes, torch.from_numpy(silence))[:, :NUM_ACTIONS]
        else:
            logits = self.net(planes)
        return torch.softmax(logits, dim=-1).numpy().astype(np.float64)

    def choose(self, probs: np.ndarray, rngs: Sequence[np.random.Generator]) -> np.ndarray:
        if self.greedy:
            return probs.argmax(axis=-1)
        # Inverse-CDF sampling, one uniform per agent from its own stream.
        cdf = probs.cumsum(axis=-1)
        u = np.array([rng.random() for rng in rngs]) * cdf[:, -1]
        return np.minimum((cdf < u[:, None]).sum(axis=-1), probs.shape[-1] - 1)

    def prefetch(self, agents: Sequence[LearnedAgent], obs: Observation) -> None:
        """Decide for `agents` (row i sees `obs.select(i)`) in one forward pass."""
        actions = self.choose(self.probabilities(obs), [a.rng for a in agents])
        for agent, action in zip(agents, actions, strict=True):
            agent.pending = int(action)


class LearnedAgent:
    """The Agent protocol over a shared `LearnedPolicy`."""

    def __init__(self, policy: LearnedPolicy):
        self.policy = policy
        self.rng = np.random.default_rng(0)
        self.pending: int | None = None

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        self.rng = rng
        self.pending = None

    def act(self, obs: Observation) -> int:
        if self.pending is None:
            self.policy.prefetch([self], Observation(*(f[None] for f in obs)))
        action, self.pending = self.pending, None
        return action


# A policy's path and its file's other keys (but `greedy`) -> its network and the file it read.
Loader = Callable[[Path, Mapping[str, Any]], tuple[PommerNet, Path]]
LOADERS: dict[str, tuple[str, Loader]] = {}  # kind -> (the key naming its path, its loader)


def register_learned_kind(kind: str, key: str, load: Loader) -> None:
    """Make policy files of `kind` playable as learned agents: `key` names the path (relative to
    the file) that `load` reads a network from, given the file's other keys."""
    LOADERS[kind] = (key, load)
    register_kind(kind, lambda spec: LearnedAgent(_shared_policy(
        kind, spec.file(key), bool(spec.params.get("greedy", False)), _options(spec, key))))


def _options(spec: PolicySpec, key: str) -> tuple[tuple[str, Any], ...]:
    """The policy file's keys that choose its network besides its path (e.g. a checkpoint's
    `module`), hashable."""
    return tuple(sorted((k, v) for k, v in spec.params.items() if k not in (key, "greedy")))


def load_learned(spec: PolicySpec) -> tuple[PommerNet, Path]:
    """A fresh network of a learned policy of any registered kind, and the file it was read
    from."""
    registered(spec.kind)  # a plugin kind's module registers its loader
    if spec.kind not in LOADERS:
        raise ValueError(f"policy {spec.name!r} (kind {spec.kind!r}) is not a learned policy; "
                         f"learned kinds: {sorted(LOADERS)}")
    key, load = LOADERS[spec.kind]
    return load(spec.file(key), dict(_options(spec, key)))


@cache
def _shared_policy(kind: str, path: Path, greedy: bool,
                   options: tuple[tuple[str, Any], ...]) -> LearnedPolicy:
    net, source = LOADERS[kind][1](path, dict(options))
    return LearnedPolicy(net, greedy, source)


def _load_weights(path: Path, options: Mapping[str, Any]) -> tuple[PommerNet, Path]:
    return load_policy_net(path), path


register_learned_kind("learned", "weights", _load_weights)


def greedy_actor(name_or_path: str) -> tuple[Callable[[Observation], np.ndarray], Path]:
    """The most likely actions (B,) of a learned policy for observations (B,), batched, and the
    file its weights were read from (for a `rllib_checkpoint` policy, the checkpoint's module
    state). `data/` takes it as DAgger's actor from the caller (`collect --dagger`)."""
    spec = resolve_policy(name_or_path)
    agent = innermost(make_agent(name_or_path))
    if not isinstance(agent, LearnedAgent) or spec.filters:
        raise ValueError(f"policy {name_or_path!r} is not a plain learned policy "
                         f"(kind {spec.kind!r}, filters {list(spec.filters)})")
    return (lambda obs: agent.policy.probabilities(obs).argmax(-1)), agent.policy.source
