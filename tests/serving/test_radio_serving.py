"""TeamRadio over the competition's protocol (game type 3, as in 2019): the observation's
`message` reaches the served agent through `radio_act`, the answer is [move, word, word], our
client sends the message and takes the words, and a served radio net plays the in-process match."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rllib_pommer.agents.http_agent import HttpAgent
from rllib_pommer.agents.registry import make_agent
from rllib_pommer.agents.speaker import radio_act
from rllib_pommer.arena.match import MatchSpec, play_match, record_games
from rllib_pommer.game.constants import RADIO_PRESET, GameType
from rllib_pommer.game.engine import Game
from rllib_pommer.game.serialize import dump_observation
from rllib_pommer.serving.policy_host import PolicyHost, Seat

from .conftest import games_played, http_policy
from .test_http_agent import fake_remote
from .test_server import post

SEAT = 1
RADIO = int(GameType.TEAM_RADIO)


def radio_observations(steps: int, seed: int = 3) -> list[tuple]:
    """SEAT's (observation, message) over the first steps of a radio game of random turns."""
    game, rng = Game(RADIO_PRESET), np.random.default_rng(seed)
    obs, seen = game.reset(seed), []
    for _ in range(steps):
        seen.append((obs.select(SEAT), game.message[SEAT].copy()))
        obs, *_ = game.step(rng.integers(0, [5, 8, 8], size=(4, 3)))
    return seen


def action_body(obs, message) -> dict:
    return {"obs": json.dumps(dump_observation(obs, message)), "action_space": "6"}


def test_a_served_radio_net_hears_the_message_and_answers_move_and_words(serve, radio_policy):
    path = str(radio_policy(greedy=False))
    port, seen = serve(path), radio_observations(20)
    assert post(port, "init_agent", {"id": str(SEAT), "game_type": str(RADIO),
                                     "seed": "7"}).json() == {"success": True}
    served = [post(port, "action", action_body(o, m)).json()["action"] for o, m in seen]
    local = make_agent(path)
    local.reset(SEAT, RADIO, np.random.default_rng(7))
    assert served == [list(radio_act(local, o, m)) for o, m in seen]
    assert len({tuple(turn[1:]) for turn in served}) > 3  # it speaks, and not one pair only


def test_a_served_speakers_words_are_reproducible_from_a_generator_state(serve):
    """A `_words` agent draws its words from a child stream; from a sent generator state the
    child is the same on every start, so the same seed gives the same words."""
    seen, state = radio_observations(12), np.random.default_rng([3, 1]).bit_generator.state
    games = []
    for port in (serve("simple_words"), serve("simple_words")):
        for _ in range(2):
            post(port, "init_agent", {"id": str(SEAT), "game_type": str(RADIO),
                                      "seed": json.dumps(state)})
            games.append([post(port, "action", action_body(o, m)).json()["action"]
                          for o, m in seen])
    assert games[1:] == games[:1] * 3 and len({tuple(t[1:]) for t in games[0]}) > 3


def test_a_silent_agent_answers_silence_and_team_games_stay_plain(serve):
    port, (obs, message) = serve("simple"), radio_observations(1)[0]
    post(port, "init_agent", {"id": str(SEAT), "game_type": str(RADIO)})
    answer = post(port, "action", action_body(obs, message)).json()["action"]
    assert answer[0] in range(6) and answer[1:] == [0, 0]
    post(port, "init_agent", {"id": str(SEAT), "game_type": "2"})
    team_obs = {"obs": json.dumps(dump_observation(obs._replace(game_type=np.int32(2))))}
    assert post(port, "action", team_obs).json()["action"] in range(6)


@pytest.mark.parametrize("message, error", [
    (None, "observation of agent 1.message: expected [word, word], got None"),
    ([3], "observation of agent 1.message: expected [word, word], got [3]"),
    ([3, 8], "observation of agent 1.message: value 8 outside [0, 7]"),
    ([3, "5"], "observation of agent 1.message: expected an integer, got '5'"),
    ([3, True], "observation of agent 1.message: expected an integer, got True"),
    ("35", "observation of agent 1.message: expected [word, word], got '35'"),
])
def test_a_bad_message_in_a_radio_game_is_a_400_naming_the_field(serve, message, error):
    port, (obs, _) = serve("static_words"), radio_observations(1)[0]
    post(port, "init_agent", {"id": str(SEAT), "game_type": str(RADIO)})
    fields = dump_observation(obs)
    if message is not None:
        fields["message"] = message
    response = post(port, "action", {"obs": json.dumps(fields)})
    assert response.status_code == 400 and response.json()["error"] == error
    assert len(post(port, "action", action_body(obs, [1, 2])).json()["action"]) == 3


@pytest.mark.parametrize("started, sent, error", [
    (2, 3, "is of game type 3 (TEAM_RADIO), but /init_agent started game type 2 (TEAM)"),
    (1, 3, "is of game type 3 (TEAM_RADIO), but /init_agent started game type 1 (FFA)"),
    (3, 2, "is of game type 2 (TEAM), but /init_agent started game type 3 (TEAM_RADIO)"),
])
def test_an_observation_of_another_game_type_is_a_400(serve, started, sent, error):
    """The agent plays the game `/init_agent` started: a TeamRadio observation in a Team game
    would get a plain move, its words unheard (issue 50, case 21)."""
    port, (obs, message) = serve("simple_words"), radio_observations(1)[0]
    post(port, "init_agent", {"id": str(SEAT), "game_type": str(started)})
    body = action_body(obs._replace(game_type=np.int32(sent)), message if sent == RADIO else None)
    response = post(port, "action", body)
    assert response.status_code == 400
    assert response.json()["error"] == (f"observation of agent {SEAT} {error}: start each game "
                                        f"with /init_agent of its own type")


def test_our_client_sends_the_message_and_takes_the_words(serve):
    received, asked = [], []
    port = serve(fake_remote((200, '{"action": [2, 3, 4]}'), (200, '{"action": 1}'),
                             (200, '{"action": [4, 0, 7]}'), 0.3, received=received,
                             asked=asked))
    agent = HttpAgent("127.0.0.1", [port], timeout=0.1)
    agent.reset(SEAT, RADIO, np.random.default_rng(0))
    assert received[0]["game_type"] == str(RADIO)
    (obs, _), = radio_observations(1)
    assert radio_act(agent, obs, (5, 6)) == (2, 3, 4)
    assert radio_act(agent, obs, (1, 1)) == (1, 0, 0)  # a plain move: silence
    assert radio_act(agent, obs, (0, 2)) == (4, 0, 7)
    assert radio_act(agent, obs, (0, 3)) == (0, 0, 0)  # no answer in time: Stop and silence
    assert [json.loads(body["obs"])["message"] for body in asked] == [[5, 6], [1, 1], [0, 2],
                                                                       [0, 3]]


@pytest.mark.parametrize("text, game_type", [
    ('{"action": [2, 8, 0]}', RADIO), ('{"action": [2, 3]}', RADIO),
    ('{"action": [6, 0, 0]}', RADIO), ('{"action": [2, 3, 4, 5]}', RADIO),
    ('{"action": [2, "3", 4]}', RADIO), ('{"action": [2, 3, 4]}', 2),
])
def test_a_malformed_radio_answer_is_an_error_naming_server_seat_and_answer(serve, text,
                                                                            game_type):
    port = serve(fake_remote((200, text)))
    agent = HttpAgent("127.0.0.1", [port])
    agent.reset(SEAT, game_type, np.random.default_rng(0))
    (obs, _), = radio_observations(1)
    expected = "<integer 0..5> or [<integer 0..5>, <word 0..7>, <word>]" if game_type == RADIO \
        else "<integer 0..5>"
    with pytest.raises(ValueError) as info:
        radio_act(agent, obs, (0, 0))
    assert str(info.value).startswith(f"remote agent at 127.0.0.1:{port} (agent 1) answered "
                                      f"/action with {text!r}")
    assert str(info.value).endswith(f"expected {{\"action\": {expected}}}")


def test_a_served_radio_net_plays_exactly_the_in_process_radio_match(serve, tmp_path,
                                                                      radio_policy):
    path = str(radio_policy(greedy=False))
    remote = str(http_policy(tmp_path, [serve(path), serve(path)], timeout=5))
    local = dict(team=path, vs="simple_words", games=1, seed=8, variant="radio")
    served = play_match(MatchSpec(**{**local, "team": remote}), workers=1)
    assert games_played(served) == games_played(play_match(MatchSpec(**local), workers=1))
    turns = [step["full_actions"] for step in record_games(MatchSpec(**local), 1)[0]["steps"]]
    served_turns = [step["full_actions"] for step in record_games(
        MatchSpec(**{**local, "team": remote}), 1)[0]["steps"]]
    assert served_turns == turns and any(t[s][1:] != [0, 0] for t in turns for s in (0, 2)
                                         if isinstance(t[s], list))


def test_warming_up_leaves_the_served_radio_games_unchanged():
    """The warm-up plays a throwaway TeamRadio game too (its kernels compile then); a warmed
    speaker then answers a real radio game word for word as a cold one does."""
    seen = radio_observations(15)
    cold, warm = PolicyHost("simple_words", seed=4), PolicyHost("simple_words", seed=4)
    warm.warm_up()
    assert warm.seat is None and warm.games_started == 0
    answers = []
    for host in (cold, warm):
        host.start_game(Seat(SEAT, RADIO))
        answers.append([host.act(obs, message.tolist()) for obs, message in seen])
    assert answers[0] == answers[1]
    assert any(words != [0, 0] for _, *words in answers[0])  # it speaks
