"""Speaking agents (TeamRadio): silent by default; a `_words` agent keeps its moves and adds two
words 0..7 per step from a stream seeded by the game."""

from __future__ import annotations

import numpy as np

from rllib_pommer.agents.registry import make_agent
from rllib_pommer.agents.speaker import SILENCE, words_of
from rllib_pommer.game.constants import RADIO_PRESET, GameType
from rllib_pommer.game.engine import Game


def _play(name: str, seed: int, steps: int = 40) -> tuple[list[int], list[tuple]]:
    """Seat 0's moves and words over the first `steps` steps of a radio game of four `name`s."""
    game = Game(RADIO_PRESET)
    obs = game.reset(seed)
    agents = [make_agent(name) for _ in range(4)]
    for seat, agent in enumerate(agents):
        agent.reset(seat, int(GameType.TEAM_RADIO), np.random.default_rng([seed, seat]))
    moves, words = [], []
    for _ in range(steps):
        actions = [[agent.act(obs.select(seat)), *words_of(agent)]
                   for seat, agent in enumerate(agents)]
        moves.append(actions[0][0])
        words.append(tuple(actions[0][1:]))
        obs, _, done, _ = game.step(actions)
        if done:
            break
    return moves, words


def test_speakers_keep_their_moves_and_draw_seeded_words():
    silent_moves, silent_words = _play("simple", 3)
    moves, words = _play("simple_words", 3)
    assert moves == silent_moves
    assert set(silent_words) == {SILENCE}
    assert len(set(words)) > 10 and all(0 <= w <= 7 for pair in words for w in pair)
    assert _play("simple_words", 3) == (moves, words)
    assert _play("simple_words", 4)[1] != words
