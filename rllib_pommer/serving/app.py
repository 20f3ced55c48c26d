"""The HTTP side: an aiohttp application answering the protocol for one `PolicyHost`.

Handlers run the agent on the event loop itself: requests of one game arrive one at a time, and a
thread hop would only add latency. Malformed requests get HTTP 400 with `{"error": message}`;
bodies above `MAX_BODY_BYTES` get 413 from aiohttp before they are read. Any other failure is a
500 for that request only: the server keeps running. A client gets `read_timeout` seconds to send
a whole request (headers from the moment it connects or was last answered, then the body): a
stalled one is cut off, with 408 if its headers had arrived. Connections and error logs are
bounded as `limits` describes.
"""

from __future__ import annotations

import asyncio
import signal
from collections.abc import Awaitable, Callable

from aiohttp import web

from .limits import MAX_CONNECTIONS, BoundedSite, connection_limit, limit_logs
from .policy_host import PolicyHost, Seat
from .protocol import BadRequest, parse_action, parse_body, parse_episode_end, parse_init_agent

DEFAULT_PORT = 10080
# An observation is about 12 kB as the runner encodes it; anything far larger is not one.
MAX_BODY_BYTES = 64 * 1024
# Seconds to send a request; the runner sends one within milliseconds of opening or reusing its
# connection. A keep-alive connection idle this long is closed too (clients reconnect).
READ_TIMEOUT_S = 10.0

HOST = web.AppKey("host", PolicyHost)
STOP = web.AppKey("stop", asyncio.Event)
READ_TIMEOUT = web.AppKey("read_timeout", float)
ANSWERING = web.AppKey("answering", set)  # the connections whose request is being answered

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]
SUCCESS = {"success": True}


@web.middleware
async def _bad_requests_as_400(request: web.Request, handler: Handler) -> web.StreamResponse:
    try:
        return await handler(request)
    except BadRequest as exc:
        return web.json_response({"error": str(exc)}, status=400)


@web.middleware
async def _mark_answering(request: web.Request, handler: Handler) -> web.StreamResponse:
    """Keeps `ANSWERING` current, so the connection limit closes idle connections first."""
    answering = request.app[ANSWERING]
    answering.add(request.protocol)
    try:
        return await handler(request)
    finally:
        answering.discard(request.protocol)


async def _read(request: web.Request) -> bytes:
    seconds = request.app[READ_TIMEOUT]
    try:
        async with asyncio.timeout(seconds):
            return await request.read()
    except TimeoutError:
        raise web.HTTPRequestTimeout(
            text=f"request body not received within {seconds:g} s") from None


async def _body(request: web.Request):
    return parse_body(await _read(request))


async def ping(request: web.Request) -> web.Response:
    return web.json_response(SUCCESS)


async def init_agent(request: web.Request) -> web.Response:
    init = parse_init_agent(await _body(request))
    request.app[HOST].start_game(Seat(init.agent_id, init.game_type), init.seed)
    return web.json_response(SUCCESS)


async def action(request: web.Request) -> web.Response:
    host = request.app[HOST]
    body = await _body(request)
    seat = host.seated("/action")
    obs, message = parse_action(body, seat.agent_id, seat.game_type)
    return web.json_response({"action": host.act(obs, message)})


async def episode_end(request: web.Request) -> web.Response:
    parse_episode_end(await _body(request))
    request.app[HOST].end_game()
    return web.json_response(SUCCESS)


async def shutdown(request: web.Request) -> web.Response:
    """Answers first: whoever runs the server stops it once `STOP` is set. The body, whatever
    it holds, is read: aiohttp would otherwise keep the connection open to drain it, and the
    server's stop would wait for that, up to 10 s."""
    await _read(request)
    request.app[STOP].set()
    return web.json_response(SUCCESS)


def make_app(host: PolicyHost, read_timeout: float = READ_TIMEOUT_S) -> web.Application:
    app = web.Application(client_max_size=MAX_BODY_BYTES,
                          middlewares=[_mark_answering, _bad_requests_as_400])
    app[HOST] = host
    app[STOP] = asyncio.Event()
    app[READ_TIMEOUT] = read_timeout
    app[ANSWERING] = set()
    app.router.add_get("/ping", ping)
    app.router.add_post("/init_agent", init_agent)
    app.router.add_post("/action", action)
    app.router.add_post("/episode_end", episode_end)
    app.router.add_post("/shutdown", shutdown)
    return app


async def start(app: web.Application, host: str, port: int,
                max_connections: int = MAX_CONNECTIONS) -> tuple[web.AppRunner, int]:
    """Start serving `app` (port 0: any free port) to at most `max_connections` clients at once
    (fewer if `limits.connection_limit` says so); returns the runner and the bound port."""
    limit_logs()
    # aiohttp closes a connection that has not sent a whole request `keepalive_timeout` seconds
    # after it opened or was last answered.
    runner = web.AppRunner(app, access_log=None,
                           keepalive_timeout=app.get(READ_TIMEOUT, READ_TIMEOUT_S))
    await runner.setup()
    site = BoundedSite(runner, host, port, connection_limit(max_connections),
                       answering=app.get(ANSWERING, set()).__contains__)
    try:
        await site.start()
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
