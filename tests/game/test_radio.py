"""TeamRadio (docs/rules.md §10): words go into the state before the step, a plain move or a
dead agent sends (0, 0), each agent hears its teammate's words of the step that produced its
observation, bad words are refused, and words never change the game itself."""

from __future__ import annotations

import numpy as np
import pytest

from rllib_pommer.game.constants import RADIO_PRESET, TEAM_PRESET, Item
from rllib_pommer.game.engine import Game, Games
from rllib_pommer.game.records import GameRecorder, observation_dicts, read_games, write_games
from rllib_pommer.game.serialize import load_state
from rllib_pommer.game.verify import verify_game

FAR = {0: (0, 0), 1: (10, 0), 2: (10, 10), 3: (0, 10)}


def _open_board(dead: tuple[int, ...] = (), bomb_under: int | None = None) -> dict:
    """A radio state on an empty board, agents in the corners (`dead` ones not drawn), and
    optionally a bomb about to go off under agent `bomb_under`."""
    game = Game(RADIO_PRESET)
    game.reset(0)
    state = game.dump()
    board = [[int(Item.PASSAGE)] * 11 for _ in range(11)]
    for seat, entry in enumerate(state["agents"]):
        entry["position"] = list(FAR[seat])
        entry["is_alive"] = seat not in dead
        if seat not in dead:
            board[FAR[seat][0]][FAR[seat][1]] = int(Item.AGENT0) + seat
    bombs = []
    if bomb_under is not None:
        bombs.append({"position": list(FAR[bomb_under]), "bomber_id": bomb_under, "life": 1,
                      "blast_strength": 2, "moving_direction": None})
    state.update(board=board, items=[], flames=[], bombs=bombs, step_count=0)
    return state


def test_words_land_in_the_state_and_the_teammate_hears_them():
    game = Game.from_state(_open_board(dead=(3,)), RADIO_PRESET)
    assert game.message.tolist() == [[0, 0]] * 4
    # agent 0 speaks, 1 passes a plain move, 2 speaks, 3 is dead and tries to speak
    game.step([[1, 3, 4], 2, [0, 7, 0], [0, 5, 5]])
    assert game.dump()["radio_from_agent"] == [[3, 4], [0, 0], [7, 0], [0, 0]]
    assert game.message.tolist() == [[7, 0], [0, 0], [3, 4], [0, 0]]
    messages = [obs["message"] for obs in observation_dicts(game.batch, 0)]
    assert messages == [[7, 0], [0, 0], [3, 4], [0, 0]]
    # the next step overwrites: words are the last step's only
    game.step([[0, 1, 1], [0, 6, 2], 0, 0])
    assert game.dump()["radio_from_agent"] == [[1, 1], [6, 2], [0, 0], [0, 0]]
    assert game.message.tolist() == [[0, 0], [0, 0], [1, 1], [6, 2]]


def test_an_agent_dying_in_a_step_has_sent_its_words_and_then_falls_silent():
    game = Game.from_state(_open_board(bomb_under=1), RADIO_PRESET)
    game.step([0, [0, 2, 5], 0, 0])
    state = game.dump()
    assert not state["agents"][1]["is_alive"]
    assert state["radio_from_agent"][1] == [2, 5]  # alive when the step began
    assert game.message[3].tolist() == [2, 5]
    game.step([0, [0, 6, 6], 0, 0])
    assert game.dump()["radio_from_agent"][1] == [0, 0]  # dead when this step began
    assert game.message[3].tolist() == [0, 0]


def test_a_reset_is_silent_and_a_loaded_state_keeps_its_words():
    game = Game(RADIO_PRESET)
    game.reset(5)
    assert game.dump()["radio_from_agent"] == [[0, 0]] * 4
    assert all(obs["message"] == [0, 0] for obs in observation_dicts(game.batch, 0))
    game.step([[0, 1, 2], [0, 3, 4], [0, 5, 6], [0, 7, 0]])
    saved = game.dump()
    game.reset(6)
    assert game.message.tolist() == [[0, 0]] * 4
    resumed = Game.from_state(saved, RADIO_PRESET)
    assert resumed.message.tolist() == [[5, 6], [7, 0], [1, 2], [3, 4]]
    assert resumed.dump() == saved


def test_observations_say_game_type_3_and_the_v2_env():
    game = Game(RADIO_PRESET)
    game.reset(1)
    obs = observation_dicts(game.batch, 0)[2]
    assert (obs["game_type"], obs["game_env"]) == (3, "pommerman.envs.v2:Pomme")
    assert obs["teammate"] == Item.AGENT0 and obs["enemies"] == [11, 13, 9]
    assert list(obs)[-1] == "message"


def test_team_dumps_carry_no_radio_fields():
    game = Game(TEAM_PRESET)
    game.reset(1)
    game.step([0, 0, 0, 0])
    assert "radio_from_agent" not in game.dump()
    obs = observation_dicts(game.batch, 0)[0]
    assert "message" not in obs and obs["game_env"] == "pommerman.envs.v0:Pomme"


@pytest.mark.parametrize(("actions", "message"), [
    ([0, [1, 8, 0], 0, 0], r"game 0 agent 1: word 8 out of range 0\.\.7"),
    ([0, 0, [1, 0, -1], 0], r"game 0 agent 2: word -1 out of range 0\.\.7"),
    ([[6, 0, 0], 0, 0, 0], r"game 0 agent 0: action 6 out of range 0\.\.5"),
    ([0, 0, 0, [1, 2]], r"game 0 agent 3: expected a move or \[move, word, word\]"),
    ([0, 0, 0, [1, 2, 3, 4]], r"game 0 agent 3: expected a move or \[move, word, word\]"),
    ([0, [1, 2.5, 3], 0, 0], r"game 0 agent 1: expected a move or \[move, word, word\]"),
    ([[1, 2, 3]] * 3, r"expected 4 moves or \[move, word, word\] per game"),
])
def test_bad_words_are_refused_naming_agent_and_value(actions, message):
    game = Game.from_state(_open_board(), RADIO_PRESET)
    with pytest.raises(ValueError, match=message):
        game.step(actions)
    assert game.dump()["step_count"] == 0  # nothing was stepped


def test_batched_bad_word_names_the_game_and_words_need_a_radio_game():
    games = Games(3, RADIO_PRESET)
    games.reset([1, 2, 3])
    actions = np.zeros((3, 4, 3), np.int64)
    actions[2, 1, 2] = 11
    with pytest.raises(ValueError, match="game 2 agent 1: word 11 out of range"):
        games.step(actions)
    actions = actions.astype(object)
    actions[2, 1, 2], actions[1, 0, 1] = 0, 0.5
    with pytest.raises(ValueError, match="game 1 agent 0: word 0.5 is not an integer"):
        games.step(actions)
    team = Games(2, TEAM_PRESET)
    team.reset([1, 2])
    with pytest.raises(ValueError, match="words are sent in TeamRadio games only"):
        team.step(np.zeros((2, 4, 3), np.int64))


def test_a_loaded_state_with_bad_words_names_the_field():
    state = _open_board()
    state["radio_from_agent"] = [[0, 0], [0, 9], [0, 0], [0, 0]]
    with pytest.raises(ValueError, match=r"state.radio_from_agent\[1\]: value 9 outside \[0, 7\]"):
        load_state(state)
    state["radio_from_agent"] = [[0, 0]] * 3
    with pytest.raises(ValueError, match="state.radio_from_agent: expected 4 pairs"):
        load_state(state)


def test_words_never_change_the_game():
    """Radio games with random words play exactly the Team games of the same moves; only the
    words differ, and each agent hears its teammate's."""
    n, rng = 16, np.random.default_rng(4)
    seeds = rng.integers(0, 2**31, n)
    moves = rng.choice([0, 1, 2, 3, 4, 5, 5], size=(300, n, 4))
    words = rng.integers(0, 8, size=(300, n, 4, 2))
    team, radio = Games(n, TEAM_PRESET), Games(n, RADIO_PRESET)
    team.reset(seeds)
    radio.reset(seeds)
    for t in range(300):
        was_alive, was_done = radio.alive.copy(), radio.done.copy()
        team.step(moves[t])
        radio.step(np.concatenate([moves[t, ..., None], words[t]], axis=-1))
        for field in ("board", "agents", "bombs", "flames", "items", "meta"):
            assert np.array_equal(getattr(team.state, field), getattr(radio.state, field))
        assert np.array_equal(team.rewards, radio.rewards)
        sent = np.where(was_alive[..., None], words[t], 0)
        assert np.array_equal(radio.state.radio[~was_done], sent[~was_done])
        assert np.array_equal(radio.message, radio.state.radio[:, [2, 3, 0, 1]])
        if radio.done.all():
            break
    assert radio.done.sum() > n // 2


def test_recorded_radio_game_keeps_ints_and_words_and_replays_exactly(tmp_path):
    rng = np.random.default_rng(2)
    game = Game(RADIO_PRESET)
    game.reset(13)
    recorder = GameRecorder(game.batch, 0, 13, agent_mix="WSWS")
    recorder.start()
    done = False
    while not done:
        actions = [[int(rng.integers(6)), *map(int, rng.integers(8, size=2))]
                   if seat % 2 == 0 else int(rng.integers(6)) for seat in range(4)]
        done = game.step(actions)[2]
        recorder.step(actions)
    record = recorder.finish()
    path = tmp_path / "radio.jsonl.gz"
    write_games(path, [record])
    (loaded,) = read_games(path)
    assert loaded["env_id"] == "PommeRadioCompetition-v2"
    first = loaded["steps"][0]
    assert isinstance(first["full_actions"][1], int) and len(first["full_actions"][0]) == 3
    assert first["actions"] == [a if isinstance(a, int) else a[0] for a in first["full_actions"]]
    assert first["observations"][2]["message"] == first["full_actions"][0][1:]
    steps, mismatches = verify_game(loaded)
    assert steps == loaded["num_steps"] > 0 and mismatches == []
