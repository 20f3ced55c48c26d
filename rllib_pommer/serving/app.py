"""The HTTP side: an aiohttp application answering the protocol for one `PolicyHost`.

Handlers run the agent on the event loop itself: requests of one game arrive one at a time, and a
thread hop would only add latency. Malformed requests get HTTP 400 with `{"error": message}`;
bodies above `MAX_BODY_BYTES` get 413 from aiohttp before they are read. Any other failure is a
500 for that request only: the server keeps running.
"""

from __future__ import annotations

import asyncio
import signal
from collections.abc import Awaitable, Callable

from aiohttp import web

from .policy_host import PolicyHost, Seat
from .protocol import BadRequest, parse_action, parse_body, parse_episode_end, parse_init_agent

DEFAULT_PORT = 10080
# An observation is about 12 kB as the runner encodes it; anything far larger is not one.
MAX_BODY_BYTES = 64 * 1024

HOST = web.AppKey("host", PolicyHost)
STOP = web.AppKey("stop", asyncio.Event)

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]
SUCCESS = {"success": True}


@web.middleware
async def _bad_requests_as_400(request: web.Request, handler: Handler) -> web.StreamResponse:
    try:
        return await handler(request)
    except BadRequest as exc:
        return web.json_response({"error": str(exc)}, status=400)


async def _body(request: web.Request):
    return parse_body(await request.read())


async def ping(request: web.Request) -> web.Response:
    return web.json_response(SUCCESS)


async def init_agent(request: web.Request) -> web.Response:
    init = parse_init_agent(await _body(request))
    request.app[HOST].start_game(Seat(init.agent_id, init.game_type), init.seed)
    return web.json_response(SUCCESS)


async def action(request: web.Request) -> web.Response:
    host = request.app[HOST]
    body = await _body(request)
    obs = parse_action(body, host.seated("/action").agent_id)
    return web.json_response({"action": host.act(obs)})


async def episode_end(request: web.Request) -> web.Response:
    parse_episode_end(await _body(request))
    request.app[HOST].end_game()
    return web.json_response(SUCCESS)


async def shutdown(request: web.Request) -> web.Response:
    """Answers first: whoever runs the server stops it once `STOP` is set."""
    request.app[STOP].set()
    return web.json_response(SUCCESS)


def make_app(host: PolicyHost) -> web.Application:
    app = web.Application(client_max_size=MAX_BODY_BYTES, middlewares=[_bad_requests_as_400])
    app[HOST] = host
    app[STOP] = asyncio.Event()
    app.router.add_get("/ping", ping)
    app.router.add_post("/init_agent", init_agent)
    app.router.add_post("/action", action)
    app.router.add_post("/episode_end", episode_end)
    app.router.add_post("/shutdown", shutdown)
    return app


async def start(app: web.Application, host: str, port: int) -> tuple[web.AppRunner, int]:
    """Start serving `app` (port 0: any free port); returns the runner and the bound port."""
    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    try:
        await web.TCPSite(runner, host, port).start()
    except OSError:
        await runner.cleanup()
        raise
    return runner, runner.addresses[0][1]


async def serve_until_stopped(app: web.Application, host: str, port: int,
                              on_ready: Callable[[int], None]) -> None:
    """Serve until /shutdown, SIGINT or SIGTERM; `on_ready` gets the bound port."""
    runner, bound_port = await start(app, host, port)
    loop = asyncio.get_running_loop()
    for signum in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(signum, app[STOP].set)
    try:
        on_ready(bound_port)
        await app[STOP].wait()
    finally:
        await runner.cleanup()
