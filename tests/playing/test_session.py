"""The played game itself: the seats are the arena's, the page shows the person's fog, the
record verifies, and only a learned seat brings torch in."""

from __future__ import annotations

import subprocess
import sys

import pytest

from rllib_pommer.agents.registry import make_agent
from rllib_pommer.arena.match import MatchSpec, record_games
from rllib_pommer.game.constants import TEAM_PRESET, Action
from rllib_pommer.game.seeding import game_seeds
from rllib_pommer.game.verify import verify_games
from rllib_pommer.playing.session import HumanGame, PlaySpec
from rllib_pommer.viz.frames import frames
from rllib_pommer.viz.page import encode_frame

from ..serving.conftest import http_policy


def team_result(record: dict, seat: int) -> str:
    """The result for `seat`'s team from the engine's final info."""
    info = record["final_info"]
    if info["result_name"] == "Incomplete":
        return "unfinished"
    winners = info.get("winners", [])
    return "tie" if not winners else "win" if seat in winners else "loss"


def test_a_person_playing_like_simple_agent_plays_the_arenas_game():
    """The board, the other seats and their random streams are game 0 of `evaluate --seed`."""
    seed = 5
    game = HumanGame(PlaySpec("simple", "static", seat=0, seed=seed))
    shadow = make_agent("simple")  # what the arena's agent on seat 0 would press
    shadow.reset(0, int(TEAM_PRESET.game_type), game_seeds(seed, 0)[1][0])
    while not game.over:
        game.advance(shadow.act(game.obs.select(0)) if game.human_alive else Action.STOP)
    (arena,) = record_games(MatchSpec("simple", "static", games=1, seed=seed), 1,
                            observations=True)
    record = game.record()
    assert record["initial_state"] == arena["initial_state"]
    assert record["steps"] == arena["steps"]
    assert record["human_result"] == team_result(record, 0) != "unfinished"


def test_the_page_sees_the_persons_fog_and_the_game_plays_out_after_death():
    spec = PlaySpec("static", "simple", seat=3, seed=1)
    game = HumanGame(spec)
    views = [game.view()]
    game.advance(Action.BOMB)
    views.append(game.view())
    while not game.over:
        game.advance(Action.STOP)
        views.append(game.view())
    record = game.record()
    assert not views[-1]["alive"] and views[-1]["over"]
    died = next(t for t, v in enumerate(views) if not v["alive"])
    assert all(s["actions"][3] == Action.STOP for s in record["steps"][died:])
    seen = frames(record, spec.seat)
    assert [v["cells"] for v in views] == [encode_frame(f) for f in seen]
    assert [v["step"] for v in views] == list(range(len(seen)))
    assert record["human_result"] == views[-1]["result"] == team_result(record, spec.seat)
    assert verify_games([record]).mismatches == []
    with pytest.raises(ValueError, match="the game is over"):
        game.advance(Action.STOP)


def test_bad_seats_actions_and_policies_are_named():
    with pytest.raises(ValueError, match="seat must be one of 0..3, got 4"):
        PlaySpec("simple", "static", seat=4)
    with pytest.raises(ValueError, match="unknown policy 'nosuch'"):
        HumanGame(PlaySpec("simple", "nosuch"))
    game = HumanGame(PlaySpec("simple", "static"))
    with pytest.raises(ValueError, match="action 6 is not one of 0..5"):
        game.advance(6)
    assert game.step == 0


def test_a_remote_opponent_plays_as_it_would_in_process(serve, tmp_path):
    remote = str(http_policy(tmp_path, [serve("simple"), serve("simple")]))
    moves = [Action.DOWN, Action.RIGHT, Action.BOMB] + [Action.STOP] * 12
    records = []
    for vs in (remote, "simple"):
        game = HumanGame(PlaySpec("static", vs, seat=2, seed=8))
        for action in moves:
            game.advance(action)
        records.append(game.record())
    assert records[0]["steps"] == records[1]["steps"]


def _loaded_after_playing(team: str) -> str:
    """Heavy packages loaded by the command's imports and a step of a game, in a fresh
    interpreter (the layering rule of tests/test_layering.py, for the play path)."""
    code = ("import sys, rllib_pommer.play; from rllib_pommer.playing.session import HumanGame, "
            f"PlaySpec; g = HumanGame(PlaySpec({team!r}, 'static')); g.advance(0); "
            "print(','.join(m for m in ('torch', 'ray', 'gymnasium') if m in sys.modules))")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip()


def test_torch_comes_in_only_with_a_learned_seat_and_ray_and_gymnasium_never():
    assert _loaded_after_playing("simple") == ""
    assert _loaded_after_playing("imitation") == "torch"
