"""The search agent as a fixed RLlib module: a league opponent or teammate a curriculum can name.

A policy of kind "search" (`agents/registry.KINDS`: fixed = "search") is played by
`SearchModule`, which runs `agents/search.search_actions`, the very function the arena's
`SearchAgent` calls, at the effort of the policy's file, on the rows rebuilt from the "raw"
part of the observation (`game/raw_codec.py`). The agent's memory (`agents/belief.py`: one flat
int64 row, its random stream included) rides in RLlib's per-agent episode state, so the module
holds nothing the weight sync could overwrite. A fresh row's stream is seeded from a hash of its
first observation, as scripted modules seed theirs (`fixed_modules._seed_streams`).
"""

from __future__ import annotations

import numpy as np
from ray.rllib.core.columns import Columns
from ray.rllib.core.rl_module import RLModule

from ..agents.belief import MEMORY_SIZE, RNG, STARTED
from ..agents.registry import resolve_policy
from ..agents.search import Effort, search_actions
from ..game.raw_codec import unpack_raw
from .fixed_modules import _numpy, _seed_streams


class SearchModule(RLModule):
    """model_config: {"policy": a policy of kind "search", "max_seq_len": ...}."""

    def setup(self):
        spec = resolve_policy(self.model_config["policy"])
        if spec.kind != "search":
            raise ValueError(f"policy {spec.name!r} is of kind {spec.kind!r}, not 'search'")
        self.effort = Effort.from_params(spec.params, str(spec.path))

    def is_stateful(self) -> bool:
        return True

    def get_initial_state(self) -> dict:
        return {"memory": np.zeros(MEMORY_SIZE, np.int64)}

    def _act(self, batch, **kwargs):
        raw = _numpy(batch[Columns.OBS]["raw"])[:, -1]  # stateful modules get a time rank of 1
        memory = _numpy(batch[Columns.STATE_IN]["memory"]).astype(np.int64)  # a copy
        fresh = memory[:, STARTED] == 0
        if fresh.any():
            memory[fresh, RNG] = _seed_streams(raw[fresh]).view(np.int64)
        actions = search_actions(unpack_raw(raw), memory, self.effort)
        return {Columns.ACTIONS: actions, Columns.STATE_OUT: {"memory": memory}}

    _forward_inference = _act
    _forward_exploration = _act

    def _forward_train(self, batch, **kwargs):
        raise NotImplementedError("the search module is never trained")

    def get_state(self, *args, **kwargs) -> dict:
        return {}

    def set_state(self, state) -> None:
        pass
