"""Words for TeamRadio (docs/rules.md §10): one radio turn of any agent, and an agent that speaks.

Every agent plays a TeamRadio step through `radio_act`, wherever it plays (the arena, the
Gymnasium env's other seats, the served agent, the browser seat's teammate and opponents). Two
optional methods beside the Agent protocol make an agent take part in the channel:
`hear(message)` receives the teammate's last two words before the agent acts, and `words()` gives
the two words it sends with the move it just chose. An agent without `hear` does not listen; one
without `words` is silent and sends (0, 0), as a plain move does in the reference. Wrappers (the
filters) keep the wrapped agent as `.inner`, so the methods are looked up down that chain: a
filtered learned agent still hears and speaks.

`Speaker` wraps any agent (the registry's `_words` suffix) and draws two uniform words 0..7 per step
from its own stream, a child of the Generator its `reset` receives, taken after the wrapped agent
has drawn its seeds: the moves are exactly those of the silent agent, and the words are
reproducible from the game's seed. It does not listen itself, so what it wraps still hears. The
words carry no meaning; they exercise the channel (replays, the arena, a teammate's `message`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..game.constants import RADIO_NUM_WORDS, RADIO_VOCAB_SIZE
from ..game.observation import Observation
from ..game.serialize import load_words
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


def _with(agent: Agent, method: str):
    """The first agent down `agent`'s wrappers (`.inner`) that has `method`, or None."""
    while agent is not None and not callable(getattr(agent, method, None)):
        agent = getattr(agent, "inner", None)
    return agent


def speaks(agent: Agent) -> bool:
    """Whether `agent` (or an agent it wraps) has words of its own: `words()`."""
    return _with(agent, "words") is not None


def radio_act(agent: Agent, obs: Observation, message: Sequence[int]) -> tuple[int, int, int]:
    """One TeamRadio turn: `agent` hears `message` (its teammate's last words) if it listens,
    chooses its move on `obs`, and sends its `words()`, or silence; the words are checked (a
    ValueError names the agent and the words)."""
    listener = _with(agent, "hear")
    if listener is not None:
        listener.hear(tuple(int(w) for w in message))
    move = int(agent.act(obs))
    speaker = _with(agent, "words")
    words = speaker.words() if speaker is not None else SILENCE
    return (move, *load_words(words, f"agent {int(obs.agent_id)}'s words"))


def as_passed(agent: Agent, turn: tuple[int, ...]) -> int | list[int]:
    """A turn as the reference's runner passes it on: a speaking agent's [move, word, word], a
    silent agent's plain move (the same words: (0, 0))."""
    return list(turn) if speaks(agent) else turn[0]
