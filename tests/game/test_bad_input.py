"""Bad input is refused with a ValueError that names the agent, field or value."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from rllib_pommer.game.constants import TEAM_PRESET
from rllib_pommer.game.engine import Game, Games
from rllib_pommer.game.generator import reset_game
from rllib_pommer.game.serialize import load_observation, load_state


@pytest.fixture()
def state() -> dict:
    return Game.from_state(_fresh_state()).dump()


def _fresh_state() -> dict:
    game = Game(TEAM_PRESET)
    game.reset(7)
    return game.dump()


def _game() -> Game:
    return Game.from_state(_fresh_state())


@pytest.mark.parametrize("actions", [[0, 0, 0], [0, 0, 0, 0, 0], []])
def test_wrong_number_of_actions(actions):
    with pytest.raises(ValueError, match="expected 4 actions"):
        _game().step(actions)


@pytest.mark.parametrize(("actions", "message"), [
    ([0, 6, 0, 0], r"agent 1: action 6 out of range 0\.\.5"),
    ([0, 0, -1, 0], r"agent 2: action -1 out of range"),
    ([0, 0, 0, 1.5], r"agent 3: action 1\.5 is not an integer"),
    ([0, "up", 0, 0], r"agent 1: action 'up' is not an integer"),
    ([True, 0, 0, 0], r"agent 0: action True is not an integer"),
])
def test_invalid_actions_name_the_agent_and_value(actions, message):
    with pytest.raises(ValueError, match=message):
        _game().step(np.array(actions, dtype=object))


def test_batched_invalid_action_names_the_game():
    games = Games(3, TEAM_PRESET)
    games.reset([1, 2, 3])
    actions = np.zeros((3, 4), np.int64)
    actions[2, 3] = 9
    with pytest.raises(ValueError, match="game 2 agent 3: action 9"):
        games.step(actions)
    with pytest.raises(ValueError, match="expected 4 actions per game for 3 game"):
        games.step(np.zeros((2, 4), np.int64))


def test_stepping_a_finished_game_is_refused():
    game = _game()
    state = game.dump()
    for agent in state["agents"][1:]:
        agent["is_alive"] = False
    state["board"] = [[0 if v in (11, 12, 13) else v for v in row] for row in state["board"]]
    game.load(state)
    game.step([0, 0, 0, 0])
    with pytest.raises(ValueError, match="game is over"):
        game.step([0, 0, 0, 0])


@pytest.mark.parametrize(("mutate", "message"), [
    (lambda s: s.pop("board"), "missing field 'board'"),
    (lambda s: s.pop("bombs"), "missing field 'bombs'"),
    (lambda s: s["agents"][2].pop("ammo"), r"state.agents\[2\]: missing field 'ammo'"),
    (lambda s: s.__setitem__("board", s["board"][:10]), r"state.board: expected shape \(11, 11\)"),
    (lambda s: s["board"][0].__setitem__(0, 5), "unknown item code 5 at \\[0, 0\\]"),
    (lambda s: s["board"][0].__setitem__(0, 42), "unknown item code 42"),
    (lambda s: s["agents"].pop(), "expected 4 agents"),
    (lambda s: s["agents"][1].__setitem__("position", [1, 1]), "agents 0 and 1 both alive on"),
    (lambda s: s["agents"][3].__setitem__("position", [11, 0]), r"agents\[3\].position: value 11"),
    (lambda s: s["items"].append([0, 0, 3]), "item code 3 is not a power-up"),
    (lambda s: s["bombs"].append({"position": [2, 2], "bomber_id": 7, "life": 3,
                                  "blast_strength": 2, "moving_direction": None}),
     r"bombs\[0\].bomber_id: value 7 outside"),
    (lambda s: s["flames"].append({"position": [2, 2]}), r"flames\[0\]: missing field 'life'"),
    (lambda s: s["agents"][0].__setitem__("is_alive", "yes"), "is_alive: expected a boolean"),
])
def test_malformed_state_names_the_field(state, mutate, message):
    bad = copy.deepcopy(state)
    mutate(bad)
    with pytest.raises(ValueError, match=message):
        load_state(bad)


def test_malformed_observation_names_the_field(public_games):
    from rllib_pommer.game.records import read_games

    obs = next(read_games(public_games))["initial_observations"][1]
    bad = dict(obs)
    del bad["bomb_life"]
    with pytest.raises(ValueError, match="observation of agent 1: missing field 'bomb_life'"):
        load_observation(bad, 1)


def test_reset_game_fills_a_valid_state():
    games = Games(2, TEAM_PRESET)
    reset_game(games.state, 1, np.random.default_rng(3), TEAM_PRESET)
    assert load_state(games.dump(1))  # the generated state passes validation
