"""Fixed (never trained) modules: the teammate and the league of opponents, one per policy name.

Which module plays a policy is its kind's `fixed` entry in the one table of kinds
(`agents/registry.KINDS`). Scripted policies run their kind's rule from the catalogue
(`agents/scripted.RULES`, the very function the arena's agents call) on the batch's rows, each
rebuilt from the "raw" part of the observation (`game/raw_codec.py`). Whatever a rule remembers
between steps (SimpleAgent's recent cells, previous direction and random stream; the random
stream of Random and SmartRandom) is carried in RLlib's per-agent episode state (STATE_IN ->
STATE_OUT), packed into one int64 vector, so the module itself holds nothing that
the learner-to-runner weight sync could overwrite, and an episode split over several `sample()`
calls keeps its memory. A row's stream is seeded on its first step from a hash of its first
observation (board layout and seat), so seeded episodes replay exactly; a row whose state arrives
already marked seeded keeps its stream (the arena cross-test seeds it as the arena would). Rules
that remember nothing (Static, Suicide) make stateless modules.

Learned and RLlib-checkpoint policies are frozen `PommerNet`s that act on the "planes" as their
policy file says, read by the arena's reader: sampling at the file's temperature, or greedily.
In TeamRadio (a `MultiDiscrete([6, 8, 8])` action space) a radio network (`RadioNet`) also
hears the "message" and speaks by the same rule; a Team network plays its moves alone there,
which send the words (0, 0), and so do scripted policies.
"""

from __future__ import annotations

import hashlib

import gymnasium as gym
import numpy as np
import torch
from ray.rllib.core.columns import Columns
from ray.rllib.core.distribution.torch.torch_distribution import TorchMultiCategorical
from ray.rllib.core.rl_module import RLModule
from ray.rllib.core.rl_module.rl_module import RLModuleSpec
from ray.rllib.core.rl_module.torch import TorchRLModule

from ..agents.registry import KINDS, resolve_policy
from ..agents.scripted import RULES
from ..agents.simple import RECENT_LENGTH, SimpleMemory
from ..game.raw_codec import unpack_raw
from ..imitation.learned import load_learned

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


class ScriptedModule(RLModule):
    """model_config: {"kind": a kind of `agents/scripted.RULES`, "max_seq_len": ...}."""

    def setup(self):
        self.kind = self.model_config["kind"]
        if self.kind not in RULES:
            raise ValueError(f"scripted module kind {self.kind!r} is not one of {list(RULES)}")
        self.rule = RULES[self.kind]

    def is_stateful(self) -> bool:
        return self.rule.remembers

    def get_initial_state(self) -> dict:
        return {"memory": np.zeros(MEMORY_SIZE, np.int64)} if self.is_stateful() else {}

    def _act(self, batch, **kwargs):
        raw = _numpy(batch[Columns.OBS]["raw"])
        if not self.is_stateful():
            return {Columns.ACTIONS: self.rule.actions(unpack_raw(raw), None)}
        raw = raw[:, -1]  # stateful modules get a time rank of 1
        memory = unpack_memory(_numpy(batch[Columns.STATE_IN]["memory"]), raw)
        actions = self.rule.actions(unpack_raw(raw), memory)
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
    """A frozen policy network; model_config: {"policy": a learned/rllib_checkpoint name}. It
    reads the policy file as the arena does (`imitation/learned.load_learned`) and acts as the
    file says: greedily, or sampling from its logits at the file's temperature
    (`LearnedPolicy.temper`)."""

    def setup(self):
        spec = resolve_policy(self.model_config["policy"])
        self.policy = load_learned(spec)
        self.pi = self.policy.net.requires_grad_(False)
        self.lens = ([int(n) for n in self.action_space.nvec]
                     if isinstance(self.action_space, gym.spaces.MultiDiscrete) else None)
        if self.policy.radio and self.lens is None:
            raise ValueError(f"policy {spec.name!r} is a TeamRadio network; it plays only in "
                             f"TeamRadio (env config game = \"radio\")")
        if self.lens is not None:
            self.action_dist_cls = TorchMultiCategorical.get_partial_dist_cls(
                input_lens=self.lens)

    def _forward(self, batch, **kwargs):
        obs = batch[Columns.OBS]
        if not self.policy.radio:
            logits = self.policy.temper(self.pi(obs["planes"]))
            if self.policy.greedy:
                return {Columns.ACTIONS: logits.argmax(-1)}
            if self.lens is None:
                return {Columns.ACTION_DIST_INPUTS: logits}
            # a Team network in TeamRadio: its moves alone
            return {Columns.ACTIONS: torch.distributions.Categorical(logits=logits).sample()}
        logits = self.policy.temper(self.pi(obs["planes"], obs["message"]))
        if self.policy.greedy:
            parts = logits.split(self.lens, dim=-1)
            return {Columns.ACTIONS: torch.stack([part.argmax(-1) for part in parts], -1)}
        return {Columns.ACTION_DIST_INPUTS: logits}


def fixed_module_spec(policy: str) -> RLModuleSpec:
    """The module spec playing policy `policy` (validated by the curriculum loader)."""
    kind = resolve_policy(policy).kind
    if KINDS[kind].fixed == "search":
        from .search_module import SearchModule  # which imports this module's seeding

        return RLModuleSpec(module_class=SearchModule,
                            model_config={"policy": policy, "max_seq_len": MAX_SEQ_LEN})
    if KINDS[kind].fixed == "scripted":
        return RLModuleSpec(module_class=ScriptedModule,
                            model_config={"kind": kind, "max_seq_len": MAX_SEQ_LEN})
    return RLModuleSpec(module_class=FrozenNetModule, model_config={"policy": policy})

