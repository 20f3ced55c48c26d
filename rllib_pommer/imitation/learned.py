"""Learned policies: a `PommerNet` state_dict named by a policy file, played as an Agent.

A policy file of kind "learned" names its weights (`weights = "imitation/pi.pt"`, relative to the
file) and how to act (`greedy = false` samples from the softmax with the agent's own random
stream, as PPO's stochastic policy does; `true` takes the most likely action; `temperature`,
1.0 unless said, divides the logits before a sampled choice, of a move and of a RadioNet's words
alike: below 1 sharpens the distribution toward the greedy action, above 1 flattens it;
`agents/registry.acting` reads and checks both keys with the file). Weights load with
`torch.load(weights_only=True)`: plain tensors only, no arbitrary pickle. A training run's
frozen opponents read their files here too (`load_learned`), so they act as in the arena.

Both kinds of learned policy are played here: "learned" (a state_dict file) and, registered by
`runs/checkpoints.py`, "rllib_checkpoint" (a PPO run's learner). Each kind registers the key
naming its path and the loader of its network (`register_learned_kind`); the path is resolved
against the policy file (`PolicySpec.file`), and one network is loaded per (kind, path, greedy,
temperature) (and the file's other keys, such as a checkpoint's `module`) in a process,
whichever kind.

Many agents of one policy can share one forward pass: `prefetch` computes the actions of a batch
of agents from their observations and parks each one on its agent, whose next `act` returns it.
The arena uses this to batch inference across the games a worker plays in lockstep; wrappers
(action filter, jitter correction) still call `act` as usual.

A network with memory (22 input planes: `recall.py`) is played by agents that each keep a memory
row over their game, folded in at each decision.

A TeamRadio network (`RadioNet`) is played by a `RadioAgent`, which takes part in the channel of
`agents/speaker.radio_act`: it hears its teammate's words (the net's message input; silence
until then, and always in Team) and speaks the net's two words. A Team network stays silent.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Callable, Mapping, Sequence
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import torch

from ..agents.base import innermost
from ..agents.belief import new_memory
from ..agents.registry import (
    ACTING_KEYS,
    Acting,
    PolicySpec,
    acting,
    make_agent,
    register_kind,
    registered,
    resolve_policy,
)
from ..agents.speaker import SILENCE
from ..game.constants import NUM_ACTIONS, RADIO_NUM_WORDS, RADIO_VOCAB_SIZE, has_radio
from ..game.observation import Observation
from ..util.errors import first_sentence
from .features import NUM_PLANES, message_features
from .network import PommerNet, RadioNet, build_net, is_radio_state, load_weights, planes_of
from .recall import input_planes


def load_policy_net(path: str | Path, num_outputs: int = NUM_ACTIONS,
                    radio: bool | None = None, planes: int | None = None) -> PommerNet:
    """A policy network (dropout off, eval mode) from a state_dict file, with a clear error;
    `num_outputs=1` reads a PPO value network. It is a `RadioNet` for a TeamRadio state_dict,
    a `PommerNet` for a Team one; `radio=True` asks for a `RadioNet` from either (a Team net's
    move logits exactly: `network.load_weights`), `radio=False` for a `PommerNet`. It reads the
    planes its weights read (19, or 22 with memory), or `planes` (a 19-plane file widened:
    `network.widened`)."""
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path}: a folder, not a weights file")
    if not path.is_file():
        raise ValueError(f"{path}: weights file not found")
    try:
        with warnings.catch_warnings():  # a pickle of another protocol: the error says enough
            warnings.filterwarnings("ignore", "Detected pickle protocol")
            state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises several types for corrupt or foreign files
        raise ValueError(f"{path}: not a readable weights file, a state_dict of tensors "
                         f"({first_sentence(exc)})") from None
    try:
        net = build_net(num_outputs, is_radio_state(state) if radio is None else radio,
                        planes_of(state) if planes is None else planes)
        load_weights(net, state)
    except (RuntimeError, TypeError, AttributeError, ValueError, IndexError) as exc:
        raise ValueError(f"{path}: weights do not fit {type(net).__name__} ({exc})") from None
    return net.eval()


class LearnedPolicy:
    """One network with how its policy file says to act (`Acting`); `source` is the file its
    weights were read from (a state_dict, or a checkpoint's module state). The arena shares one
    among every agent of a policy in a process; a training run's frozen module holds its own."""

    def __init__(self, net: PommerNet, source: Path, how: Acting):
        self.net = net
        self.greedy = how.greedy
        self.temperature = how.temperature
        self.source = source
        self.radio = isinstance(net, RadioNet)
        self.remembers = net.planes > NUM_PLANES  # it reads the memory planes (recall.py)

    @torch.no_grad()
    def logits(self, obs: Observation, messages: np.ndarray | None = None,
               memory: np.ndarray | None = None) -> torch.Tensor:
        """The net's logits for observations with leading shape (B,): (B, 6), or a `RadioNet`'s
        (B, 6 + 16) hearing `messages` (B, 2) (default: silence, what it hears in Team). A net
        with memory also reads the agents' memory rows (B, belief.MEMORY_SIZE), which fold these
        observations in (`recall.recall_planes`): without them it is refused, since one
        observation cannot say what the fog hides."""
        if self.remembers and memory is None:
            raise ValueError(f"the policy of {self.source} has memory (it reads "
                             f"{self.net.planes} planes): it needs its agents' memory rows, as "
                             f"its agents keep them over a game")
        planes = torch.from_numpy(input_planes(obs, memory if self.remembers else None))
        if not self.radio:
            return self.net(planes)
        if messages is None:
            messages = np.zeros((len(planes), RADIO_NUM_WORDS), np.int64)
        return self.net(planes, torch.from_numpy(message_features(messages)))

    def probabilities(self, obs: Observation, messages: np.ndarray | None = None,
                      memory: np.ndarray | None = None) -> np.ndarray:
        """Move probabilities (B, 6) at the policy's temperature, the distribution its moves are
        drawn from, for observations with leading shape (B,) (`logits`)."""
        return _softmax(self.tempered_logits(obs, messages, memory)[:, :NUM_ACTIONS])

    def tempered_logits(self, obs: Observation, messages: np.ndarray | None = None,
                        memory: np.ndarray | None = None) -> torch.Tensor:
        """`logits` at the policy's temperature (`temper`): what moves and words are drawn from."""
        return self.temper(self.logits(obs, messages, memory))

    def temper(self, logits: torch.Tensor) -> torch.Tensor:
        """The net's logits (..., 6), or a radio net's (..., 6 + 16), as logits of the same
        distributions at the policy's temperature: each categorical (the move, each word) shifted
        so that its largest logit is 0, then divided by the temperature in float64. That gives
        the probabilities of logits / T, and stays finite for any positive T: every value is at
        most 0 before the division and the largest stay 0, so as T -> 0 all the mass goes to
        the most likely choice (where logits / T itself would overflow into NaN). A T below the
        smallest normal double divides as that one does, whose distributions are already the
        most likely choice alone: torch reads a subnormal divisor as 0 where it flushes
        denormals (the trainers do)."""
        sizes = [NUM_ACTIONS] + [RADIO_VOCAB_SIZE] * RADIO_NUM_WORDS * self.radio
        parts = logits.double().split(sizes, dim=-1)
        divisor = max(self.temperature, sys.float_info.min)
        shifted = [(part - part.amax(-1, keepdim=True)) / divisor for part in parts]
        return torch.cat(shifted, -1).to(logits.dtype)

    def choose(self, probs: np.ndarray, rngs: Sequence[np.random.Generator]) -> np.ndarray:
        if self.greedy:
            return probs.argmax(axis=-1)
        # Inverse-CDF sampling, one uniform per agent from its own stream.
        cdf = probs.cumsum(axis=-1)
        u = np.array([rng.random() for rng in rngs]) * cdf[:, -1]
        return np.minimum((cdf < u[:, None]).sum(axis=-1), probs.shape[-1] - 1)

    def prefetch(self, agents: Sequence[LearnedAgent], obs: Observation,
                 messages: np.ndarray | None = None) -> None:
        """Decide for `agents` (row i sees `obs.select(i)` and hears `messages[i]`, by default
        what the agent last heard) in one forward pass: each agent's move, and the words of
        those that speak (`LearnedAgent.speaking`), drawn after the move from its own stream."""
        if messages is None:
            messages = np.array([agent.heard for agent in agents], np.int64)
        memory = np.stack([agent.memory for agent in agents]) if self.remembers else None
        logits = self.tempered_logits(obs, messages, memory)
        if memory is not None:
            for agent, row in zip(agents, memory, strict=True):
                agent.memory = row
        moves = self.choose(_softmax(logits[:, :NUM_ACTIONS]), [a.rng for a in agents])
        said = [SILENCE] * len(agents)
        talkers = [i for i, agent in enumerate(agents) if agent.speaking]
        if talkers:
            words = _softmax(logits[talkers, NUM_ACTIONS:].reshape(
                len(talkers), RADIO_NUM_WORDS, RADIO_VOCAB_SIZE))
            rngs = [agents[i].rng for i in talkers]
            chosen = np.stack([self.choose(words[:, k], rngs) for k in range(RADIO_NUM_WORDS)], -1)
            for i, pair in zip(talkers, chosen, strict=True):
                said[i] = tuple(int(w) for w in pair)
        for agent, move, words_ in zip(agents, moves, said, strict=True):
            agent.pending = (int(move), words_)


def _softmax(logits: torch.Tensor) -> np.ndarray:
    return torch.softmax(logits, dim=-1).numpy().astype(np.float64)


class LearnedAgent:
    """The Agent protocol over a shared `LearnedPolicy`. A Team net neither hears nor speaks:
    in TeamRadio it is silent (`agents/speaker.radio_act`)."""

    speaking = False  # whether `prefetch` draws words for it

    def __init__(self, policy: LearnedPolicy):
        self.policy = policy
        self.rng = np.random.default_rng(0)
        self.pending: tuple[int, tuple[int, ...]] | None = None  # (move, words) decided
        self.heard: tuple[int, ...] = SILENCE
        self.said: tuple[int, ...] = SILENCE
        self.memory = new_memory(1)[0]  # what a policy with memory saw this game (recall.py)

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        self.rng = rng
        self.pending = None
        self.heard = self.said = SILENCE
        self.memory = new_memory(1)[0]

    def act(self, obs: Observation) -> int:
        if self.pending is None:
            self.policy.prefetch([self], obs.as_row())
        (move, self.said), self.pending = self.pending, None
        return move


class RadioAgent(LearnedAgent):
    """A `LearnedAgent` over a `RadioNet`: in TeamRadio it hears its teammate's words (fed as the
    net's message instead of silence) and speaks the net's two words (argmax when greedy, else
    sampled from its own stream after its move). In Team it plays its moves hearing silence."""

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        super().reset(agent_id, game_type, rng)
        self.speaking = has_radio(game_type)

    def hear(self, message: Sequence[int]) -> None:
        """The teammate's last words, heard by this step's forward pass."""
        self.heard = tuple(int(w) for w in message)

    def words(self) -> tuple[int, ...]:
        """The words the net chose with this step's move."""
        return self.said


def learned_agent(policy: LearnedPolicy) -> LearnedAgent:
    """The agent playing `policy`: a `RadioAgent` for a radio net."""
    return RadioAgent(policy) if policy.radio else LearnedAgent(policy)


# A policy's path and its file's other keys (but how it acts) -> its network and the file it read.
Loader = Callable[[Path, Mapping[str, Any]], tuple[PommerNet, Path]]
LOADERS: dict[str, tuple[str, Loader]] = {}  # kind -> (the key naming its path, its loader)


def register_learned_kind(kind: str, key: str, load: Loader) -> None:
    """Make policy files of `kind` playable as learned agents: `key` names the path (relative to
    the file) that `load` reads a network from, given the file's other keys."""
    LOADERS[kind] = (key, load)
    register_kind(kind, lambda spec: learned_agent(load_learned(spec, shared=True)))


def _options(spec: PolicySpec, key: str) -> tuple[tuple[str, Any], ...]:
    """The policy file's keys that choose its network besides its path (e.g. a checkpoint's
    `module`), hashable."""
    return tuple(sorted((k, v) for k, v in spec.params.items()
                        if k != key and k not in ACTING_KEYS))


def load_learned(spec: PolicySpec, shared: bool = False) -> LearnedPolicy:
    """The policy of a learned policy file of any registered kind: its network, the file that
    was read from, and how the file says to act (`acting`). `shared`: the one policy of this
    process for the file's network and acting (cached), else a fresh one."""
    registered(spec.kind)  # a plugin kind's module registers its loader
    if spec.kind not in LOADERS:
        raise ValueError(f"policy {spec.name!r} (kind {spec.kind!r}) is not a learned policy; "
                         f"learned kinds: {sorted(LOADERS)}")
    key = LOADERS[spec.kind][0]
    build = _shared_policy if shared else _policy
    return build(spec.kind, spec.file(key), acting(spec), _options(spec, key))


def _policy(kind: str, path: Path, how: Acting,
            options: tuple[tuple[str, Any], ...]) -> LearnedPolicy:
    return LearnedPolicy(*LOADERS[kind][1](path, dict(options)), how)


_shared_policy = cache(_policy)


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
