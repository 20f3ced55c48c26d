"""Fixed-rule agents: the opponents and teammates of the paper's curriculum, and baselines.

StaticAgent and SimpleAgentNoBomb are the first two curriculum opponents (paper, Table 1 and
§Experimentation); SuicideTeammate removes the learner's teammate early in a game, so the learner's
reward is its own doing; RandomAgent and SmartRandom are baselines. All of them draw randomness only
from the Generator given to `reset`, so a seeded game replays exactly.
"""

from __future__ import annotations

import numpy as np

from ..game.constants import NUM_ACTIONS, Action
from ..game.observation import Observation
from .action_filter import safe_actions
from .simple import SimpleAgent


class StaticAgent:
    """Never moves and never bombs: the first curriculum opponent, a target to learn bombing on."""

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        pass

    def act(self, obs: Observation) -> int:
        return int(Action.STOP)


class RandomAgent:
    """Uniform over the six actions, ignoring the observation (rules §7)."""

    def __init__(self) -> None:
        self._rng: np.random.Generator | None = None

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        self._rng = rng

    def act(self, obs: Observation) -> int:
        return int(self._rng.integers(NUM_ACTIONS))


class SimpleAgentNoBomb:
    """SimpleAgent whose Bomb is played as Stop: the second curriculum opponent.

    It chases and traps like SimpleAgent but cannot kill, so games last long enough for the learner
    to practise following and cornering opponents.
    """

    def __init__(self) -> None:
        self.simple = SimpleAgent()

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        self.simple.reset(agent_id, game_type, rng)

    def act(self, obs: Observation) -> int:
        action = int(self.simple.act(obs))
        return int(Action.STOP) if action == Action.BOMB else action


class SuicideTeammate:
    """Lays a bomb on its first step and then stands on it (Stop) until it dies.

    With the default blast strength the bomb kills it nine steps later, leaving the learner to play
    the rest of the game alone.
    """

    def __init__(self) -> None:
        self._bomb_laid = False

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        self._bomb_laid = False

    def act(self, obs: Observation) -> int:
        if self._bomb_laid:
            return int(Action.STOP)
        self._bomb_laid = True
        return int(Action.BOMB)


class SmartRandom:
    """Uniform over the actions the action filter deems safe (Bomb included).

    When none is safe the agent is lost whatever it does, so it falls back to all six actions.
    """

    def __init__(self) -> None:
        self._rng: np.random.Generator | None = None

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        self._rng = rng

    def act(self, obs: Observation) -> int:
        candidates = np.flatnonzero(safe_actions(obs))
        if candidates.size == 0:
            return int(self._rng.integers(NUM_ACTIONS))
        return int(candidates[self._rng.integers(candidates.size)])
