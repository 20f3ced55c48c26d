"""The catalogue of scripted policies: each rule written once, over a batch of observation rows.

StaticAgent and SimpleAgentNoBomb are the first two curriculum opponents (paper, Table 1 and
§Experimentation); SuicideTeammate removes the learner's teammate early in a game, so the learner's
reward is its own doing; RandomAgent and SmartRandom are baselines; SimpleAgent is the reference's
baseline (`simple.py`).

`RULES` maps each kind to its rule: a function from observation rows (leading shape (M,)) and
their memory rows (`SimpleMemory`, updated in place) to M actions. Every player of a scripted kind
calls it: the Agent classes below with a memory of one row (the arena, serving, the browser seat,
the envs' fixed seats), and RLlib's `ScriptedModule` with the rows of a batch, its memory carried
in RLlib's episode state (`rl/fixed_modules.py`). SimpleAgent alone keeps a one-row shortcut into
the same compiled decision (`simple.py`), because it is the arena's hot path. So a rule cannot
drift between the arena and training, and a new scripted opponent is one function and one row.

Randomness comes only from each row's splitmix64 stream (`rng.py`), seeded from the Generator given
to `reset` (or, in RLlib, from the row's first observation), so a seeded game replays exactly.
Rules that remember nothing between steps (`remembers` False) get no memory: Static always stops,
Suicide bombs on the game's first step (step_count 0) and then stands on its bomb.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import njit

from ..game.constants import NUM_ACTIONS, Action
from ..game.observation import Observation
from .action_filter import safe_actions
from .rng import next_below
from .simple import SimpleAgent, SimpleMemory, new_memory, simple_actions

STOP, BOMB = int(Action.STOP), int(Action.BOMB)


@njit(cache=True)
def _uniform_batch(rng: np.ndarray) -> np.ndarray:
    """One uniform draw among the six actions per row, from the row's stream."""
    actions = np.empty(rng.shape[0], np.int64)
    for m in range(rng.shape[0]):
        actions[m] = next_below(rng, m, NUM_ACTIONS)
    return actions


def _static(obs: Observation, memory: None) -> np.ndarray:
    return np.full(obs.step_count.shape, STOP, np.int64)


def _suicide(obs: Observation, memory: None) -> np.ndarray:
    return np.where(obs.step_count == 0, np.int64(BOMB), np.int64(STOP))


def _random(obs: Observation, memory: SimpleMemory) -> np.ndarray:
    return _uniform_batch(memory.rng)


def _smart_random(obs: Observation, memory: SimpleMemory) -> np.ndarray:
    """Uniform over the actions the action filter deems safe (Bomb included); when none is, the
    agent is lost whatever it does, so over all six."""
    actions = np.empty(len(memory.rng), np.int64)
    for m in range(len(actions)):
        candidates = np.flatnonzero(safe_actions(obs.select(m)))
        if candidates.size == 0:
            candidates = np.arange(NUM_ACTIONS)
        actions[m] = candidates[next_below(memory.rng, m, candidates.size)]
    return actions


def _simple_nobomb(obs: Observation, memory: SimpleMemory) -> np.ndarray:
    actions = simple_actions(obs, memory)
    actions[actions == BOMB] = STOP
    return actions


class ScriptedAgent:
    """The Agent protocol over the rule of `kind`, with a memory of one row."""

    kind = ""

    def __init__(self) -> None:
        self.rule = RULES[self.kind]
        self.memory: SimpleMemory | None = None

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        self.memory = new_memory(1, rng) if self.rule.remembers else None

    def act(self, obs: Observation) -> int:
        rows = Observation._make([field[None] for field in obs])  # numpy fields, scalars too
        return int(self.rule.actions(rows, self.memory)[0])


class StaticAgent(ScriptedAgent):
    """Never moves and never bombs: the first curriculum opponent, a target to learn bombing on."""

    kind = "static"


class RandomAgent(ScriptedAgent):
    """Uniform over the six actions, ignoring the observation (docs/rules.md §7)."""

    kind = "random"


class SimpleAgentNoBomb(ScriptedAgent):
    """SimpleAgent whose Bomb is played as Stop: the second curriculum opponent.

    It chases and traps like SimpleAgent but cannot kill, so games last long enough for the learner
    to practise following and cornering opponents.
    """

    kind = "simple_nobomb"


class SuicideTeammate(ScriptedAgent):
    """Lays a bomb on the game's first step and then stands on it (Stop) until it dies.

    With the default blast strength the bomb kills it nine steps later, leaving the learner to play
    the rest of the game alone.
    """

    kind = "suicide"


class SmartRandom(ScriptedAgent):
    """Uniform over the actions the action filter deems safe (Bomb included)."""

    kind = "smart_random"


class Rule(NamedTuple):
    """One scripted kind: its batched rule, whether rows keep memory between steps, and the
    Agent class that plays it one seat at a time."""

    actions: Callable[[Observation, SimpleMemory | None], np.ndarray]
    remembers: bool
    agent: type


RULES: dict[str, Rule] = {
    "static": Rule(_static, False, StaticAgent),
    "random": Rule(_random, True, RandomAgent),
    "simple": Rule(simple_actions, True, SimpleAgent),
    "simple_nobomb": Rule(_simple_nobomb, True, SimpleAgentNoBomb),
    "smart_random": Rule(_smart_random, True, SmartRandom),
    "suicide": Rule(_suicide, False, SuicideTeammate),
}
