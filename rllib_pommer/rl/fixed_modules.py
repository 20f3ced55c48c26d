"""Fixed (never trained) modules: the teammate and the league of opponents, one per policy name.

Scripted policies run the compiled agents on each row's `Observation`, rebuilt from the "raw" part
of the observation. Whatever an agent remembers between steps (SimpleAgent's recent cells,
previous direction and random stream; the random stream of Random and SmartRandom) is carried in
RLlib's per-agent episode state (STATE_IN -> STATE_OUT, rllib-notes K1), packed into one int64
vector, so the module itself holds nothing that the learner-to-runner weight sync could overwrite,
and an episode split over several `sample()` calls keeps its memory. A row's stream is seeded on
its first step from a hash of its first observation (board layout and seat), so seeded episodes
replay exactly. Static and Suicide need no memory (Suicide bombs at step 0) and are stateless.

Learned and RLlib-checkpoint policies are frozen `PommerNet`s that act by sampling (or greedily,
per their policy file) on the "planes".
"""

from __future__ import annotations

import hashlib

import numpy as np
from ray.rllib.core.columns import Columns
from ray.rllib.core.rl_module import RLModule
from ray.rllib.core.rl_module.rl_module import RLModuleSpec
from ray.rllib.core.rl_module.torch import TorchRLModule

from ..agents.action_filter import safe_actions
from ..agents.registry import resolve_policy
from ..agents.rng import next_below
from ..agents.simple import RECENT_LENGTH, SimpleMemory, simple_actions
from ..game.constants import NUM_ACTIONS, Action
from ..learned import load_policy_net
from .checkpoint_policy import checkpoint_path, load_checkpoint_net
from .env import unpack_raw

STATEFUL_KINDS = ("simple", "simple_nobomb", "random", "smart_random")
STATELESS_KINDS = ("static", "suicide")
# Packed memory: recent cells (6 x 2), recent_len, prev_dir, rng state (uint64 bits), seeded flag.
_RECENT = 2 * RECENT_LENGTH
MEMORY_SIZE = _RECENT + 4
MAX_SEQ_LEN = 20  # required by RLlib's learner connector for stateful modules; any value works


def _numpy(x) -> np.ndarray:
    return x.numpy() if hasattr(x, "numpy") else np.asarray(x)


def _seed_streams(raw: np.ndarray) -> np.ndarray:
    """One uint64 stream state per row, from a hash of the row's observation."""
    return np.array([int.from_bytes(hashlib.blake2b(row.tobytes(), digest_size=8).digest(),
                                    "little") for row in raw], np.uint64)


def unpack_memory(packed: np.ndarray, raw: np.ndarray) -> SimpleMemory:
    """SimpleMemory rows from packed state; rows never used yet get a stream from `raw`."""
    packed = packed.astype(np.int64)
    rng = packed[:, _RECENT + 2].copy().view(np.uint64)
    fresh = packed[:, _RECENT + 3] == 0
    if fresh.any():
        rng[fresh] = _seed_streams(raw[fresh])
    return SimpleMemory(
        recent=packed[:, :_RECENT].reshape(-1, RECENT_LENGTH, 2).astype(np.int32),
        recent_len=packed[:, _RECENT].astype(np.int32),
        prev_dir=packed[:, _RECENT + 1].astype(np.int32),
        rng=rng,
    )


def pack_memory(memory: SimpleMemory) -> np.ndarray:
    rows = memory.recent.shape[0]
    return np.concatenate([
        memory.recent.reshape(rows, -1).astype(np.int64),
        memory.recent_len[:, None].astype(np.int64),
        memory.prev_dir[:, None].astype(np.int64),
        memory.rng.view(np.int64)[:, None],
        np.ones((rows, 1), np.int64),
    ], axis=1)


def _simple(obs, memory):
    return simple_actions(obs, memory)


def _simple_nobomb(obs, memory):
    actions = simple_actions(obs, memory)
    actions[actions == Action.BOMB] = Action.STOP
    return actions


def _random(obs, memory):
    return np.array([next_below(memory.rng, m, NUM_ACTIONS) for m in range(len(memory.rng))])


def _smart_random(obs, memory):
    actions = np.empty(len(memory.rng), np.int64)
    for m in range(len(actions)):
        candidates = np.flatnonzero(safe_actions(obs.select(m)))
        if candidates.size == 0:
            candidates = np.arange(NUM_ACTIONS)
        actions[m] = candidates[next_below(memory.rng, m, candidates.size)]
    return actions


# Kind -> (observation rows, memory rows updated in place) -> actions; same rules as the
# Agent classes in `agents/` (random draws come from the splitmix stream in the memory).
STATEFUL_RULES = {"simple": _simple, "simple_nobomb": _simple_nobomb, "random": _random,
                  "smart_random": _smart_random}


class ScriptedModule(RLModule):
    """model_config: {"kind": one of STATEFUL_KINDS + STATELESS_KINDS, "max_seq_len": ...}."""

    def setup(self):
        self.kind = self.model_config["kind"]
        if self.kind not in STATEFUL_KINDS + STATELESS_KINDS:
            raise ValueError(f"scripted module kind {self.kind!r} is not one of "
                             f"{list(STATEFUL_KINDS + STATELESS_KINDS)}")

    def is_stateful(self) -> bool:
        return self.kind in STATEFUL_KINDS

    def get_initial_state(self) -> dict:
        return {"memory": np.zeros(MEMORY_SIZE, np.int64)} if self.is_stateful() else {}

    def _act(self, batch, **kwargs):
        raw = _numpy(batch[Columns.OBS]["raw"])
        if not self.is_stateful():
            obs = unpack_raw(raw)
            first = obs.step_count == 0
            bomb = first if self.kind == "suicide" else np.zeros_like(first)
            return {Columns.ACTIONS: np.where(bomb, int(Action.BOMB), int(Action.STOP))}
        raw = raw[:, -1]  # stateful modules get a time rank of 1
        memory = unpack_memory(_numpy(batch[Columns.STATE_IN]["memory"]), raw)
        actions = STATEFUL_RULES[self.kind](unpack_raw(raw), memory)
        return {Columns.ACTIONS: np.asarray(actions, np.int64),
                Columns.STATE_OUT: {"memory": pack_memory(memory)}}

    _forward_inference = _act
    _forward_exploration = _act

    def _forward_train(self, batch, **kwargs):
        raise NotImplementedError(f"the scripted module {self.kind!r} is never trained")

    def get_state(self, *args, **kwargs) -> dict:
        return {}

    def set_state(self, state) -> None:
        pass


class FrozenNetModule(TorchRLModule):
    """A frozen policy network; model_config: {"policy": a learned/rllib_checkpoint name}."""

    def setup(self):
        spec = resolve_policy(self.model_config["policy"])
        if spec.kind == "learned":
            net = load_policy_net((spec.path.parent / spec.params["weights"]).resolve())
        else:
            net = load_checkpoint_net(checkpoint_path(spec))
        self.pi = net.requires_grad_(False)
        self.greedy = bool(spec.params.get("greedy", False))

    def _forward(self, batch, **kwargs):
        logits = self.pi(batch[Columns.OBS]["planes"])
        if self.greedy:
            return {Columns.ACTIONS: logits.argmax(-1)}
        return {Columns.ACTION_DIST_INPUTS: logits}


def fixed_module_spec(policy: str) -> RLModuleSpec:
    """The module spec playing policy `policy` (validated by the curriculum loader)."""
    kind = resolve_policy(policy).kind
    if kind in STATEFUL_KINDS + STATELESS_KINDS:
        return RLModuleSpec(module_class=ScriptedModule,
                            model_config={"kind": kind, "max_seq_len": MAX_SEQ_LEN})
    return RLModuleSpec(module_class=FrozenNetModule, model_config={"policy": policy})

