"""The play server over HTTP: moves land on the steps they name, bad requests are refused without
touching the game, the clock and pause, one page per game, a reloaded page goes on with the
game, and a closed page that does not come back forfeits with a replay that verifies."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
from aiohttp import web

from rllib_pommer.game.constants import Action
from rllib_pommer.game.records import read_games
from rllib_pommer.game.verify import verify_games
from rllib_pommer.playing.server import MAX_BODY_BYTES, TABLE, TOKEN_HEADER
from rllib_pommer.playing.session import PlaySpec

from ..serving.conftest import http_policy
from .conftest import SPEC, Seat, run_server


def test_moves_are_played_on_the_steps_they_name(tmp_path):
    moves = ["left", 4, "BOMB", 0, "up", "down"]  # names (any case) or codes

    async def scenario(client, table):
        seat = await Seat.take(client)
        frames = [await seat.move(m, t) for t, m in enumerate(moves)]
        return frames, await seat.state()

    frames, state = run_server(scenario, tmp_path / "game.jsonl")
    expected = [Action.LEFT, Action.RIGHT, Action.BOMB, Action.STOP, Action.UP, Action.DOWN]
    assert state["step"] == len(moves)
    assert [a[SPEC.seat] for a in state["actions"]] == expected
    assert [f["actions"][SPEC.seat] for f in frames] == [a.name.capitalize() for a in expected]
    assert state["players"] == ["static", "human", "static", "simple"]
    assert not state["over"] and state["result"] == "unfinished"


BAD_MOVES = [
    (b"up", "not JSON"),
    (b"[1, 2]", "must be a JSON object"),
    ({"step": 0}, "missing field 'action'"),
    ({"action": "up"}, "missing field 'step'"),
    ({"action": 6, "step": 0}, "action 6 is not one of 0..5"),
    ({"action": -1, "step": 0}, "action -1 is not one of"),
    ({"action": "jump", "step": 0}, 'action "jump" is not one of'),
    ({"action": True, "step": 0}, "action true is not one of"),
    ({"action": 1.0, "step": 0}, "action 1.0 is not one of"),
    ({"action": "up", "step": "0"}, 'step "0" is not a step number'),
    ({"action": "up", "step": -1}, "step -1 is not a step number"),
    ({"action": "up", "step": 0, "speed": 2}, "unknown field 'speed'"),
]


def test_bad_moves_get_an_error_naming_the_problem_and_the_game_goes_on(tmp_path):
    async def scenario(client, table):
        seat = await Seat.take(client)
        answers = [await seat.post("/move", body) for body, _ in BAD_MOVES]
        refusals = [
            await seat.post("/move", {"action": "up", "step": 7}),  # not the current step
            await seat.post("/move", {"action": "up", "step": 0}, token=None),
            await seat.post("/move", {"action": "up", "step": 0}, token="guess"),
        ]
        too_big = await client.post("/move", data=b" " * (MAX_BODY_BYTES + 1),
                                    headers={TOKEN_HEADER: seat.token})
        untouched = await seat.state()
        frame = await seat.move("right", 0)
        return answers, refusals, too_big.status, untouched, frame

    answers, refusals, too_big, untouched, frame = run_server(scenario, tmp_path / "g.jsonl")
    for (status, answer), (body, message) in zip(answers, BAD_MOVES, strict=True):
        assert status == 400, body
        assert message in answer["error"], (body, answer)
    assert refusals[0] == (409, {"error": "move for step 7, but the game is at step 0"})
    assert [r[0] for r in refusals[1:]] == [403, 403]
    assert "does not hold the seat" in refusals[1][1]["error"]
    assert too_big == 413
    assert untouched["step"] == 0 and untouched["actions"] == [] and not untouched["over"]
    assert frame["step"] == 1 and frame["actions"][SPEC.seat] == "Right"


def test_one_move_per_step(tmp_path):
    async def scenario(client, table):
        seat = await Seat.take(client)
        first, second = await asyncio.gather(
            seat.post("/move", {"action": "up", "step": 0}),
            seat.post("/move", {"action": "down", "step": 0}))
        await seat.next_message()
        return first, second, await seat.state()

    first, second, state = run_server(scenario, tmp_path / "g.jsonl")
    assert first[0] == 200 and second[0] == 409, (first, second)
    assert second[1]["error"] in ("step 0 already has your move (up)",
                                  "move for step 0, but the game is at step 0 (being played)",
                                  "move for step 0, but the game is at step 1")
    assert state["step"] == 1 and state["actions"][0][SPEC.seat] == Action.UP


def test_no_key_within_the_turn_time_plays_stop_and_pause_stops_the_clock(tmp_path):
    async def scenario(client, table):
        seat = await Seat.take(client)
        while (await seat.next_message())["step"] < 3:
            pass
        status, settings = await seat.post("/settings", {"paused": True})
        await asyncio.sleep(0.15)  # a step already being played finishes
        paused_at = (await seat.state())["step"]
        await asyncio.sleep(0.4)
        still = (await seat.state())["step"]
        blocked = await seat.post("/move", {"action": "up", "step": still})
        bad = [await seat.post("/settings", body) for body in
               ({"turn_time": 0}, {"turn_time": "soon"}, {"paused": "yes"}, {"speed": 2})]
        await seat.post("/settings", {"paused": False, "turn_time": "wait"})
        resumed = await seat.move("up", still)
        return settings, paused_at, still, blocked, bad, resumed, await seat.state()

    settings, paused_at, still, blocked, bad, resumed, state = run_server(
        scenario, tmp_path / "g.jsonl", turn_time=0.05)
    assert settings == {"turnTime": 0.05, "paused": True}
    assert still == paused_at >= 3
    assert blocked == (409, {"error": "the game is paused; resume it to move"})
    assert [b[0] for b in bad] == [400] * 4
    assert "turn time 0 is neither" in bad[0][1]["error"]
    assert 'turn time "soon" is neither' in bad[1][1]["error"]
    assert "paused must be true or false" in bad[2][1]["error"]
    assert "unknown field 'speed'" in bad[3][1]["error"]
    assert resumed["turnTime"] is None and not resumed["paused"]
    human = [a[SPEC.seat] for a in state["actions"]]
    assert human == [Action.STOP] * still + [Action.UP]


def test_a_dead_persons_moves_are_refused_and_the_others_play_on(tmp_path):
    async def scenario(client, table):
        seat = await Seat.take(client)
        frame = await seat.move("bomb", 0)
        while frame["alive"]:  # stand on the bomb
            frame = await seat.move("stop", frame["step"])
        refused = await seat.post("/move", {"action": "up", "step": frame["step"]})
        later = await seat.next_message()  # the clock plays on without the person
        return frame, refused, later

    frame, refused, later = run_server(scenario, tmp_path / "g.jsonl")
    assert frame["agents"][SPEC.seat][0] is False
    assert refused == (409, {"error": f"your agent (agent {SPEC.seat}) is dead; the others "
                                      f"play on"})
    assert later["step"] == frame["step"] + 1


def test_a_second_page_is_refused_and_the_first_plays_on(tmp_path):
    async def scenario(client, table):
        seat = await Seat.take(client)
        page = await client.get("/")
        second = await client.ws_connect("/seat")
        refused = await second.receive_json(timeout=5)
        closed = await second.receive()
        frame = await seat.move("up", 0)
        return page.status, await page.text(), refused, closed.type, frame

    status, text, refused, closed, frame = run_server(scenario, tmp_path / "g.jsonl")
    assert status == 200 and "<canvas" in text  # the page is served; its socket is refused
    assert refused == {"type": "refused",
                       "error": "this game is already being played in another page"}
    assert closed.name == "CLOSE"
    assert frame["step"] == 1


def test_a_page_not_back_in_time_forfeits_and_saves_a_replay_that_verifies(tmp_path):
    out = tmp_path / "game.jsonl.gz"

    async def scenario(client, table):
        page = await client.get("/")
        assert page.status == 200 and "<canvas" in await page.text()
        seat = await Seat.take(client)
        for t, action in enumerate(["down", "right", "bomb"]):
            await seat.move(action, t)
        await seat.socket.close()
        await asyncio.sleep(0.1)
        waited = not table.game.over  # the seat is kept for the reconnect time (0.5 s)
        await asyncio.wait_for(table.done.wait(), 10)
        after = await client.get("/")
        return await seat.state(), after.status, waited

    state, after, waited = run_server(scenario, out, reconnect=0.5)
    assert waited
    assert state["over"] and state["result"] == "forfeit" and state["replay"] == str(out)
    assert after == 409
    (record,) = read_games(out)
    assert record["forfeit"] == {"seat": SPEC.seat, "step": 3, "reason": "the page was closed"}
    assert record["human_result"] == "forfeit" and record["num_steps"] == 3
    assert [s["actions"][SPEC.seat] for s in record["steps"]] == [2, 4, 5]
    report = verify_games([record])
    assert (report.games, report.steps, report.mismatches) == (1, 3, [])


def test_a_page_back_within_the_reconnect_time_goes_on_with_the_game(tmp_path):
    """A reload: the clock (a step per 0.05 s) plays no step while no page holds the seat, the
    new page is served and seated in the same game, the old page's token is refused, and the
    new page's moves land; it may leave and come back again."""
    async def settle(seat: Seat) -> int:
        """Stop the clock's own steps (turn time "wait") and return the step it rests on."""
        assert (await seat.post("/settings", {"turn_time": "wait"}))[0] == 200
        await asyncio.sleep(0.2)  # a step under way when the setting came lands first
        return (await seat.state())["step"]

    async def move(seat: Seat, action: str, step: int) -> None:
        assert (await seat.post("/move", {"action": action, "step": step}))[0] == 200
        while (await seat.next_message())["step"] != step + 1:
            pass  # frames of the steps the clock played before

    async def scenario(client, table):
        first = await Seat.take(client)
        await first.socket.close()
        await asyncio.sleep(0.3)
        away = [(await first.state())["step"]]
        await asyncio.sleep(0.5)
        away.append((await first.state())["step"])
        page = await client.get("/")
        second = await Seat.take(client)
        stale = await first.post("/settings", {"paused": True})
        step = await settle(second)
        await move(second, "right", step)
        await second.socket.close()
        third = await Seat.take(client)
        await move(third, "bomb", step + 1)
        actions = [a[SPEC.seat] for a in (await third.state())["actions"]]
        return away, page.status, stale[0], step, actions, table.game.over

    away, page, stale, step, actions, over = run_server(scenario, tmp_path / "g.jsonl",
                                                        turn_time=0.05, reconnect=5.0)
    assert away[0] == away[1] and page == 200 and stale == 403 and not over
    assert actions[step:] == [int(Action.RIGHT), int(Action.BOMB)]


def test_a_page_closed_before_any_move_saves_an_empty_game(tmp_path):
    out = tmp_path / "game.jsonl"

    async def scenario(client, table):
        seat = await Seat.take(client)
        await seat.socket.close()
        await asyncio.wait_for(table.done.wait(), 10)

    run_server(scenario, out)
    (record,) = read_games(out)
    assert record["num_steps"] == 0 and record["forfeit"]["step"] == 0
    assert verify_games([record]).mismatches == []


def broken_remote() -> web.Application:
    """A remote agent that takes its seat, then answers /action with an action out of range."""
    async def init_agent(request: web.Request) -> web.Response:
        return web.json_response({"success": True})

    async def action(request: web.Request) -> web.Response:
        return web.json_response({"action": 9})

    app = web.Application()
    app.router.add_post("/init_agent", init_agent)
    app.router.add_post("/action", action)
    return app


def test_a_failing_agent_stops_the_game_which_is_saved_and_told(serve, tmp_path):
    remote = http_policy(tmp_path, [serve(broken_remote()), serve(broken_remote())])
    out = tmp_path / "game.jsonl"

    async def scenario(client, table):
        seat = await Seat.take(client)
        await seat.post("/move", {"action": "up", "step": 0})
        over = await seat.next_message("over")
        await asyncio.wait_for(table.done.wait(), 10)
        return over, table.errors

    over, errors = run_server(scenario, out, spec=PlaySpec("simple", str(remote), seat=0))
    assert over["over"] and over["result"] == "unfinished" and over["replay"] == str(out)
    assert errors == [over["error"]]
    assert over["error"].startswith("the game stopped at step 0: remote agent at 127.0.0.1:")
    assert "answered /action with" in over["error"]
    (record,) = read_games(out)
    assert record["stopped"]["step"] == 0 and record["num_steps"] == 0


def test_a_replay_that_cannot_be_written_is_saved_to_a_printed_fallback(tmp_path):
    """The --out folder passed the up-front check, then went away mid-game (issue 40, case 1):
    the game is kept in a fallback file, which the table and the page name."""
    folder = tmp_path / "replays"
    folder.mkdir()
    out = folder / "game.jsonl.gz"

    async def scenario(client, table):
        seat = await Seat.take(client)
        await seat.move("left", 0)
        folder.rmdir()
        await seat.socket.close()
        await asyncio.wait_for(table.done.wait(), 10)
        return table.saved, table.errors

    saved, errors = run_server(scenario, out)
    try:
        assert saved is not None and saved != out and saved.name.endswith(".jsonl.gz")
        assert errors == [f"could not write the replay to {out} ([Errno 2] No such file or "
                          f"directory: '{out}'); saved it to {saved} instead"]
        (record,) = read_games(saved)
        assert record["num_steps"] == 1 and verify_games([record]).mismatches == []
    finally:
        if saved is not None:
            saved.unlink(missing_ok=True)


def test_play_prints_where_the_fallback_replay_went(tmp_path, monkeypatch, capsys):
    """The command's own lines: the replay's real place, and exit 1 for the failed write."""
    import rllib_pommer.play as play

    fallback = tmp_path / "fallback.jsonl.gz"

    async def served(app, host, port, announce):
        table = app[TABLE]
        table.saved, table.errors = fallback, ["could not write the replay to x; saved it"]
        return table

    monkeypatch.setattr(play, "serve_game", served)
    assert play.main(["--team", "static", "--vs", "static", "--out",
                      str(tmp_path / "game.jsonl.gz")]) == 1
    out = capsys.readouterr().out
    assert f"replay saved to {fallback}: python -m rllib_pommer.replay html {fallback}" in out


def test_a_replay_under_proc_goes_to_the_fallback(tmp_path):
    """/proc passes the up-front check (os.access: writable), yet takes no file (issue 40)."""
    from rllib_pommer.util.outputs import check_output

    out = Path("/proc/game.jsonl")
    if not out.parent.is_dir():
        pytest.skip("no /proc here")
    try:
        check_output(out, "--out")
    except ValueError:
        pytest.skip("refused up front here (not root)")

    async def scenario(client, table):
        seat = await Seat.take(client)
        await seat.socket.close()
        await asyncio.wait_for(table.done.wait(), 10)
        return table.saved

    saved = run_server(scenario, out)
    try:
        assert saved is not None and saved.suffix == ".jsonl"
        (record,) = read_games(saved)
        assert record["num_steps"] == 0
    finally:
        if saved is not None:
            saved.unlink(missing_ok=True)
