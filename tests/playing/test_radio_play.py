"""`play --variant radio`: the person's words reach their teammate and the teammate's reach the
page, every agent plays its turn through `radio_act` as in the arena, the server takes words
with the seat's token and refuses bad ones without touching the game, and Team play is as it
was (no words)."""

from __future__ import annotations

import pytest

from rllib_pommer.agents.registry import make_agent
from rllib_pommer.agents.speaker import radio_act
from rllib_pommer.arena.match import MatchSpec, record_games
from rllib_pommer.game.constants import GameType
from rllib_pommer.game.seeding import game_seeds
from rllib_pommer.game.verify import verify_games
from rllib_pommer.play import main as play_main
from rllib_pommer.playing.session import HumanGame, PlaySpec

from .conftest import Seat, run_server


def test_words_flow_both_ways_between_the_person_and_a_radio_teammate(radio_policy):
    game = HumanGame(PlaySpec(str(radio_policy(greedy=True)), "static_words", seat=1, seed=2,
                              variant="radio"))
    partner = game.agents[3]
    heard = []
    partner.policy.net.hear.register_forward_hook(
        lambda _, inputs, out: heard.append(inputs[0].reshape(2, 8).argmax(-1).tolist()))
    said, views = [[3, 5], [7, 0], [1, 1]], []
    for words in said:
        game.say(words)
        game.advance(0)
        views.append(game.view()["radio"])
    assert heard == [[0, 0], [3, 5], [7, 0]]  # the teammate hears the person's last words
    assert [v["saying"] for v in views] == said
    record = game.record()
    assert [step["full_actions"][1] for step in record["steps"]] == [[0, *w] for w in said]
    partner_said = [step["full_actions"][3][1:] for step in record["steps"]]
    assert [v["heard"] for v in views] == partner_said and partner_said != [[0, 0]] * 3
    assert [v["words"] for v in views] == [[[], w, [], p] for w, p in zip(said, partner_said,
                                                                             strict=True)]
    assert verify_games([record]).mismatches == []


def test_a_person_playing_like_the_radio_net_plays_the_arenas_radio_game(radio_policy):
    """Turns one agent at a time (the play session) equal the arena's batched turns."""
    path, seed = str(radio_policy(greedy=False)), 6
    game = HumanGame(PlaySpec(path, "simple_words", seat=0, seed=seed, variant="radio"))
    shadow = make_agent(path)  # what the arena's agent on seat 0 would do
    shadow.reset(0, int(GameType.TEAM_RADIO), game_seeds(seed, 0)[1][0])
    while not game.over and game.step < 60:
        if game.human_alive:
            move, *words = radio_act(shadow, game.obs.select(0), game.game.message[0])
            game.say(words)
        game.advance(move if game.human_alive else 0)
    (arena,) = record_games(MatchSpec(path, "simple_words", 1, seed=seed, variant="radio"), 1,
                            observations=True)
    steps = game.record()["steps"]
    assert steps == arena["steps"][:len(steps)]


def test_words_are_checked_and_team_games_have_none():
    game = HumanGame(PlaySpec("simple", "static", variant="radio"))
    with pytest.raises(ValueError, match=r"words: value 8 outside \[0, 7\]"):
        game.say([8, 0])
    assert game.words == (0, 0)
    team = HumanGame(PlaySpec("simple", "static"))
    assert team.view()["radio"] is None
    with pytest.raises(ValueError, match="words are sent in TeamRadio games only"):
        team.say([1, 2])
    with pytest.raises(ValueError, match="variant 'ffa': play is a team game"):
        PlaySpec("simple", "static", variant="ffa")
    with pytest.raises(SystemExit):  # argparse: --variant is team or radio
        play_main(["--team", "simple", "--vs", "static", "--variant", "ffa"])


RADIO = PlaySpec("static_words", "static", seat=1, seed=3, variant="radio")


def test_the_server_takes_words_with_the_token_and_refuses_bad_ones(tmp_path):
    async def scenario(client, table):
        seat = await Seat.take(client)
        refusals = [await seat.post("/words", body) for body in (
            {"words": [8, 1]}, {"words": "35"}, {}, {"words": [1, 2], "loud": True})]
        refusals.append(await seat.post("/words", {"words": [1, 2]}, token=None))
        untouched = list(table.game.words)
        accepted = await seat.post("/words", {"words": [6, 4]})
        frame = await seat.move("stop", 0)
        return refusals, untouched, accepted, frame, await seat.state()

    refusals, untouched, accepted, frame, state = run_server(scenario, tmp_path / "r.jsonl",
                                                             spec=RADIO)
    assert [status for status, _ in refusals] == [400, 400, 400, 400, 403]
    assert refusals[0][1]["error"] == "words: value 8 outside [0, 7]"
    assert "expected [word, word], got '35'" in refusals[1][1]["error"]
    assert "missing field 'words'" in refusals[2][1]["error"]
    assert "unknown field 'loud'" in refusals[3][1]["error"]
    assert untouched == [0, 0] and accepted == (200, {"saying": [6, 4]})
    assert frame["radio"]["saying"] == [6, 4] and frame["radio"]["words"][1] == [6, 4]
    teammate_words = state["full_actions"][0][3][1:]
    assert frame["radio"]["heard"] == teammate_words  # a `_words` teammate: seeded words
    assert state["full_actions"][0][1] == [0, 6, 4]


def test_words_in_a_team_game_are_refused(tmp_path):
    async def scenario(client, table):
        seat = await Seat.take(client)
        return await seat.post("/words", {"words": [1, 2]}), await seat.state()

    (status, answer), state = run_server(scenario, tmp_path / "t.jsonl")
    assert status == 409 and "words are sent in TeamRadio only" in answer["error"]
    assert "full_actions" not in state and state["step"] == 0


def test_the_page_knows_the_game_is_radio(tmp_path):
    async def scenario(client, table):
        return await (await client.get("/")).text()

    page = run_server(scenario, tmp_path / "p.jsonl", spec=RADIO)
    assert '"radio":true' in page and "TeamRadio: You (agent 1)" in page
