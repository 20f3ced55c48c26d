"""The protocol every agent follows, scripted or learned.

An agent is reset for each new game with its seat, the game type and a numpy Generator (the only
source of its randomness, so a seeded game is reproducible), then asked for one action per step on
its own `Observation` (leading shape ()). Dead agents are not asked; the engine plays Stop for them.
In TeamRadio an agent may also listen and speak, with the optional `hear` and `words` that
`speaker.radio_act` calls around `act`.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from ..game.observation import Observation


@runtime_checkable
class Agent(Protocol):
    """Anything that can take a seat: reset per game, then one action per observation."""
    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        """Forget the last game; remember the seat and draw any seeds from `rng`."""

    def act(self, obs: Observation) -> int:
        """One action code 0..5 for this observation."""


def innermost(agent: Agent) -> Agent:
    """The agent at the core of its wrappers (the filters keep the wrapped agent as `.inner`)."""
    while hasattr(agent, "inner"):
        agent = agent.inner
    return agent
