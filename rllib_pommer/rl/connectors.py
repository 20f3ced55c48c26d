"""The action filter and jitter correction as a module-to-env connector piece: the learner's, and
those a fixed opponent's name asks for (`simple_action` is SimpleAgent behind the action filter).

The paper post-processes the policy's actions: the Action Filter (vetoes moves into flames) in some
episodes and the Jitter Correction (SimpleAgent takes over when the agent loops) in others. Doing
it here rather than in the env means the executed action is the one stored in the episode: the
piece overwrites the ACTIONS column and recomputes ACTION_LOGP from the module's logits, so PPO
trains on what was executed with a consistent probability ratio.

Which filters are on is decided per episode by the env's seeded stream (the `filters` info) and
read once per learner agent (two where the learner is its own teammate) into
`episode.custom_data`, together with the wrappers that apply them: the registry turns the
switches into its filter names and stacks its wrappers (`registry.switched_on`,
`registry.with_filters`) around a stand-in that returns the module's action. Their memory
(positions, the expert SimpleAgent's memory, random streams) therefore lives with the episode,
seeded from the episode's first observation. Counts of learner steps and overridden actions go
to custom_data for the episode-end metrics.

A fixed module named with the registry's filter suffixes (`_jitter`, `_action`, `_jitter_action`)
has its filters on in every episode; they are kept apart (FIXED_FILTERS_KEY), so the learner's
counts stay the learner's.

In TeamRadio an action is [move, word, word]: the filters see and replace the move alone, the
words pass through, and the log-probability is the whole action's under the module's
multi-categorical distribution.
"""

from __future__ import annotations

import numpy as np
import torch
from ray.rllib.connectors.connector_v2 import ConnectorV2
from ray.rllib.core.columns import Columns

from ..agents.registry import FILTER_SWITCHES, resolve_policy, switched_on, with_filters
from ..curriculum.names import LEARNER
from ..game.constants import TEAM_PRESET
from ..game.raw_codec import unpack_raw
from .teacher import TeacherLabels

FILTERS_KEY = "learner_filters"
FIXED_FILTERS_KEY = "fixed_filters"


def fixed_filter_flags(module_id: str) -> dict[str, bool]:
    """The switches always on for a fixed module (as the env's `filters` info names them): those
    of the filters its policy name's suffix asks for (none for a module id that is no policy
    name, as self-play snapshots)."""
    try:
        filters = resolve_policy(module_id).filters
    except ValueError:
        return {}
    return {FILTER_SWITCHES[name]: True for name in filters}


class ModuleAction:
    """An Agent that plays the action the RL module chose (the core of the wrapper stack)."""

    action = 0

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        pass

    def act(self, obs) -> int:
        return self.action


class EpisodeFilters:
    """One episode's wrapper stack for the learner, and its counts: `flags` are the episode's
    filter switches (the env's `filters` info)."""

    def __init__(self, flags: dict, seat: int, first_raw: np.ndarray):
        self.flags = flags
        self.core = ModuleAction()
        agent = with_filters(self.core, switched_on(flags))
        agent.reset(seat, int(TEAM_PRESET.game_type),
                    np.random.default_rng(np.frombuffer(first_raw.tobytes(), np.uint8)))
        self.agent = agent
        self.steps = 0
        self.overridden = 0

    def act(self, action: int, raw: np.ndarray) -> int:
        self.core.action = action
        executed = int(self.agent.act(unpack_raw(raw))) if self.agent is not self.core else action
        self.steps += 1
        self.overridden += executed != action
        return executed


def move_of(action) -> int:
    """The move of an action: itself, or a TeamRadio [move, word, word]'s first part."""
    return int(action[0]) if np.ndim(action) else int(action)


def with_move(action, move: int):
    """`action` with its move replaced: an int, or a TeamRadio [move, word, word] (a copy)."""
    if not np.ndim(action):
        return move
    replaced = np.array(action)
    replaced[0] = move
    return replaced


class LearnerFilters(ConnectorV2):
    """Module-to-env piece: the learner's action through its episode's jitter correction and
    action filter (when on), with ACTION_LOGP recomputed for the executed action; a fixed
    module's through the filters its name asks for."""
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._fixed_flags: dict[str, dict[str, bool]] = {}

    def __call__(self, *, rl_module, batch, episodes, explore=None, shared_data=None,
                 metrics=None, **kwargs):
        by_id = {episode.id_: episode for episode in episodes}
        for key, actions in batch[Columns.ACTIONS].items():
            episode_id, agent_id, module_id = key
            if module_id != LEARNER:
                if module_id not in self._fixed_flags:
                    self._fixed_flags[module_id] = fixed_filter_flags(module_id)
                if not self._fixed_flags[module_id]:
                    continue
            episode = by_id[episode_id]
            agent_episode = episode.agent_episodes[agent_id]
            raw = agent_episode.get_observations(-1)["raw"]
            store = FILTERS_KEY if module_id == LEARNER else FIXED_FILTERS_KEY
            by_agent = episode.custom_data.setdefault(store, {})
            filters = by_agent.get(agent_id)
            if filters is None:
                flags = (agent_episode.get_infos(-1).get("filters", {}) if module_id == LEARNER
                         else self._fixed_flags[module_id])
                filters = by_agent[agent_id] = EpisodeFilters(flags, agent_id, raw)
            action = actions[0]
            chosen = move_of(action)
            executed = filters.act(chosen, raw)
            if executed == chosen:
                continue
            actions[0] = with_move(action, executed)
            if module_id == LEARNER and Columns.ACTION_LOGP in batch:  # by the module's own
                # distribution, as PPO's learner recomputes it: the ratio of an overridden row
                # starts at exactly 1
                logits = torch.as_tensor(batch[Columns.ACTION_DIST_INPUTS][key][0])
                dist = rl_module[LEARNER].get_exploration_action_dist_cls().from_logits(logits)
                logp = dist.logp(torch.as_tensor(actions[0])).item()  # a float32's value
                batch[Columns.ACTION_LOGP][key][0] = np.float32(logp)
        return batch


def learner_filters(env=None, spaces=None, device=None, *, teacher: str = "") -> list[ConnectorV2]:
    """Our module-to-env pieces (`module_to_env_connector`; RLlib's own unbatch before them and
    listify after): the filters, and with a `teacher` policy its moves (teacher.py)."""
    return [LearnerFilters()] + ([TeacherLabels(teacher=teacher)] if teacher else [])
