"""The client side: our arena as the competition's runner, against fake remote agents."""

from __future__ import annotations

import asyncio
import json
import time

import numpy as np
import pytest
from aiohttp import web

from rllib_pommer.agents.http_agent import HttpAgent
from rllib_pommer.agents.registry import make_agent
from rllib_pommer.arena.match import MatchSpec, play_match

from .conftest import games_played, http_policy, running, team_observations

OBS = team_observations(1, 1)[0]


def fake_remote(*answers, received: list | None = None,
                asked: list | None = None) -> web.Application:
    """Answers /action with `answers` in turn, the last one from then on: a (status, text) pair,
    or a delay in seconds before answering Stop. Bodies of /init_agent go to `received`, those
    of /action to `asked`."""
    queue = list(answers)

    async def init_agent(request: web.Request) -> web.Response:
        if received is not None:
            received.append(await request.json())
        return web.json_response({"success": True})

    async def action(request: web.Request) -> web.Response:
        if asked is not None:
            asked.append(await request.json())
        answer = queue.pop(0) if len(queue) > 1 else queue[0]
        if isinstance(answer, float):
            await asyncio.sleep(answer)
            answer = (200, '{"action": 0}')
        status, text = answer
        return web.Response(status=status, text=text, content_type="application/json")

    app = web.Application()
    app.router.add_post("/init_agent", init_agent)
    app.router.add_post("/action", action)
    return app


def seated(port: int, timeout: float = 0.15, seat: int = 1) -> HttpAgent:
    agent = HttpAgent("127.0.0.1", [port], timeout)
    agent.reset(seat, 2, np.random.default_rng(0))
    return agent


def test_init_sends_the_seat_and_our_seed_and_actions_come_back(serve):
    received = []
    port = serve(fake_remote((200, '{"action": 4}'), received=received))
    rng = np.random.default_rng([9, 9])
    agent = HttpAgent("127.0.0.1", [port])
    agent.reset(3, 2, rng)
    assert received == [{"id": "3", "game_type": "2", "seed": json.dumps(rng.bit_generator.state)}]
    assert agent.act(OBS) == 4


@pytest.mark.parametrize("status, text", [
    (200, '{"action": 6}'),
    (200, '{"action": -1}'),
    (200, '{"action": "3"}'),
    (200, '{"action": 2.0}'),
    (200, '{"action": true}'),
    (200, '{"move": 1}'),
    (200, '[1]'),
])
def test_an_action_outside_0_to_5_is_an_error_naming_server_seat_and_answer(serve, status, text):
    port = serve(fake_remote((status, text)))
    with pytest.raises(ValueError) as info:
        seated(port).act(OBS)
    assert str(info.value) == (f"remote agent at 127.0.0.1:{port} (agent 1) answered /action "
                               f"with {text!r}; expected {{\"action\": <integer 0..5>}}")


@pytest.mark.parametrize("status, text, message", [
    (500, "boom", "answered /action with HTTP 500: 'boom'"),
    (200, "Stop", "answered /action with 'Stop', which is not JSON"),
])
def test_http_errors_and_garbage_are_errors(serve, status, text, message):
    port = serve(fake_remote((status, text)))
    with pytest.raises(ValueError, match=f"127.0.0.1:{port} \\(agent 1\\) {message}"):
        seated(port).act(OBS)


def test_a_late_answer_is_stop_and_the_next_one_counts_again(serve):
    agent = seated(serve(fake_remote(0.3, (200, '{"action": 3}'))), timeout=0.05)
    start = time.perf_counter()
    assert agent.act(OBS) == 0
    assert time.perf_counter() - start < 0.25
    assert agent.act(OBS) == 3


def test_a_vanished_server_is_stop_and_an_absent_one_cannot_be_seated():
    with running(fake_remote((200, '{"action": 3}'))) as port:
        agent = seated(port)
        assert agent.act(OBS) == 3
    assert agent.act(OBS) == 0
    with pytest.raises(ValueError, match=f"127.0.0.1:{port} \\(agent 2\\) could not be seated"):
        agent.reset(2, 2, np.random.default_rng(0))


@pytest.mark.parametrize("count, expected", [
    (1, [[0, 1, 2, 3]]), (2, [[0, 1], [2, 3]]), (4, [[0], [1], [2], [3]])])
def test_seats_split_evenly_over_the_ports(serve, count, expected):
    received = [[] for _ in range(count)]
    agent = HttpAgent("127.0.0.1", [serve(fake_remote((200, "{}"), received=r)) for r in received])
    for seat in range(4):
        agent.reset(seat, 2, np.random.default_rng(0))
    assert [[int(body["id"]) for body in bodies] for bodies in received] == expected


def test_policy_files_carry_host_ports_and_timeout(tmp_path):
    agent = make_agent(http_policy(tmp_path, [10080, 10081]))
    assert isinstance(agent, HttpAgent)
    assert (agent.host, agent.ports, agent.timeout) == ("127.0.0.1", (10080, 10081), 0.15)
    path = tmp_path / "one.toml"
    path.write_text('kind = "http"\nhost = "skynet.local"\nport = 10080\ntimeout = 1\n')
    agent = make_agent(path)
    assert (agent.host, agent.ports, agent.timeout) == ("skynet.local", (10080,), 1.0)


@pytest.mark.parametrize("body, message", [
    ("", "kind 'http' needs a port"),
    ("port = 1\nprot = 2\n", r"unknown key\(s\) \['prot'\] for kind 'http'"),
    ("port = [1, 2, 3]\n", "port must be a port number or a list of 1, 2 or 4"),
    ("port = 70000\n", "port must be a port number"),
    ("port = \"10080\"\n", "port must be a port number"),
    ("port = 1\nhost = 3\n", "host must be a host name"),
    ("port = 1\ntimeout = 0\n", "timeout must be a positive number"),
])
def test_bad_http_policy_files_name_the_problem(tmp_path, body, message):
    path = tmp_path / "bad.toml"
    path.write_text('kind = "http"\n' + body)
    with pytest.raises(ValueError, match=f"policy file {path}: {message}"):
        make_agent(path)


def test_a_remote_team_that_always_times_out_plays_like_static_agents(serve, tmp_path):
    ports = [serve(fake_remote(0.03)), serve(fake_remote(0.03))]
    spec = dict(vs="simple", games=1, seed=3)
    slow = play_match(MatchSpec(str(http_policy(tmp_path, ports, timeout=0.002)), **spec),
                      workers=1)
    assert games_played(slow) == games_played(play_match(MatchSpec("static", **spec), workers=1))


def test_games_interleaved_on_one_server_are_refused(serve):
    port = serve(fake_remote((200, '{"action": 1}')))
    first, second = seated(port), seated(port)
    assert second.act(OBS) == 1
    with pytest.raises(ValueError, match=f"127.0.0.1:{port} \\(agent 1\\) has since been seated"):
        first.act(OBS)
