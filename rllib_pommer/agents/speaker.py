"""Words for TeamRadio (docs/rules.md §10): an agent that sends two words with every move.

Agents are silent by default: a player that is not a `Speaker` sends (0, 0), as a plain move does
in the reference. `Speaker` wraps any agent (the registry's `_words` suffix) and draws two uniform
words 0..7 per step from its own stream, a child of the Generator its `reset` receives, taken after
the wrapped agent has drawn its seeds: the moves are exactly those of the silent agent, and the
words are reproducible from the game's seed. The words carry no meaning yet; they exercise the
channel (replays, the arena, a teammate's `message`).
"""

from __future__ import annotations

import numpy as np

from ..game.constants import RADIO_NUM_WORDS, RADIO_VOCAB_SIZE
from ..game.observation import Observation
from .base import Agent

SILENCE = (0,) * RADIO_NUM_WORDS


class Speaker:
    """`inner`'s moves, and two uniform random words per step."""

    def __init__(self, inner: Agent):
        self.inner = inner
        self.rng: np.random.Generator | None = None

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        self.inner.reset(agent_id, game_type, rng)
        self.rng = rng.spawn(1)[0]

    def act(self, obs: Observation) -> int:
        return self.inner.act(obs)

    def words(self) -> tuple[int, ...]:
        """This step's words, drawn after its move."""
        return tuple(int(w) for w in self.rng.integers(0, RADIO_VOCAB_SIZE, RADIO_NUM_WORDS))


def words_of(agent: Agent) -> tuple[int, ...]:
    """What `agent` sends with its move: a `Speaker`'s words, else silence (0, 0)."""
    return agent.words() if isinstance(agent, Speaker) else SILENCE
