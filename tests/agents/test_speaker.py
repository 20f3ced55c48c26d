"""Speaking agents (TeamRadio): one radio turn (`radio_act`) hands an agent its teammate's words
if it listens and takes its words if it speaks, through wrappers; agents are silent by default; a
`_words` agent keeps its moves and adds two words 0..7 per step from a stream seeded by the
game."""

from __future__ import annotations

import numpy as np
import pytest

from rllib_pommer.agents.action_filter import ActionFilter
from rllib_pommer.agents.registry import make_agent
from rllib_pommer.agents.speaker import SILENCE, as_passed, radio_act, speaks
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
        actions = [list(radio_act(agent, obs.select(seat), game.message[seat]))
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


class Echo:
    """Moves Stop and says back what it heard, each word plus `shift` (mod 8)."""

    def __init__(self, shift: int = 1):
        self.shift, self.heard = shift, None

    def reset(self, agent_id, game_type, rng):
        self.heard = None

    def hear(self, message):
        self.heard = message

    def act(self, obs):
        return 0

    def words(self):
        return tuple((w + self.shift) % 8 for w in self.heard)


OBS = Game(RADIO_PRESET).reset(1).select(2)


def test_a_radio_turn_hands_the_message_and_takes_the_words_through_wrappers():
    echo = Echo()
    assert radio_act(echo, OBS, np.array([3, 7], np.uint8)) == (0, 4, 0)
    assert echo.heard == (3, 7) and all(type(w) is int for w in echo.heard)
    filtered = ActionFilter(Echo())  # a filter keeps the agent it wraps as `.inner`
    filtered.reset(2, int(GameType.TEAM_RADIO), np.random.default_rng(0))
    assert speaks(filtered) and radio_act(filtered, OBS, (1, 2)) == (0, 2, 3)
    silent = make_agent("static")
    silent.reset(2, int(GameType.TEAM_RADIO), np.random.default_rng(0))
    assert not speaks(silent) and radio_act(silent, OBS, (5, 5)) == (0, *SILENCE)
    assert as_passed(silent, (0, 0, 0)) == 0 and as_passed(echo, (0, 4, 0)) == [0, 4, 0]


def test_a_speaker_wrapping_a_listener_passes_the_message_on_and_speaks_itself():
    speaker = make_agent("static_words")
    speaker.inner = Echo(shift=0)  # hear() is looked up down the chain
    speaker.reset(2, int(GameType.TEAM_RADIO), np.random.default_rng(0))
    turn = radio_act(speaker, OBS, (6, 6))
    assert speaker.inner.heard == (6, 6) and turn[0] == 0 and all(0 <= w <= 7 for w in turn[1:])


@pytest.mark.parametrize("words, message", [
    ((8, 0), r"agent 2's words: value 8 outside \[0, 7\]"),
    ((1,), r"agent 2's words: expected \[word, word\], got \(1,\)"),
    (("a", 1), r"agent 2's words: expected an integer, got 'a'"),
])
def test_bad_words_name_the_agent_and_the_words(words, message):
    loud = Echo()
    loud.words = lambda: words
    with pytest.raises(ValueError, match=message):
        radio_act(loud, OBS, (0, 0))
