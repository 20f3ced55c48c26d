"""What keeps a server answering among clients that stall, flood or fail: a bounded number of
connections, and error logs that cannot fill the disk.

Slow clients: a socket is a file, and a process may hold only so many (`ulimit -n`, often 1024).
Idle connections that never finish their request would pile up until `accept()` fails, /ping
times out, and asyncio logs a traceback for every failed accept, tens of megabytes a minute
(docs/measurements.md). So the site admits at most `connection_limit` connections: a new one
past it closes the oldest idle one (no request being answered: still sending its request, or
between requests), so a stalled client loses its connection and a live one gets in. The read
time-out that closes stalled connections even without new arrivals is set where the app is run
(`app.start`).
"""

from __future__ import annotations

import asyncio
import logging
import resource
import time
from collections.abc import Callable

from aiohttp import web

MAX_CONNECTIONS = 256  # the competition's runner holds one connection per served agent
# Connections the kernel queues for accept(). asyncio accepts up to this many in one go, and
# sockets the limit closes are released a few loop turns later: a flood holds up to about
# `IN_FLIGHT_BACKLOGS` backlogs of files beyond the limit.
BACKLOG = 32
IN_FLIGHT_BACKLOGS = 4
# Loggers whose records a bad client can provoke over and over: failed accepts (asyncio) and
# failing requests (aiohttp's server and web loggers).
NOISY_LOGGERS = ("asyncio", "aiohttp.server", "aiohttp.web")


def connection_limit(requested: int = MAX_CONNECTIONS) -> int:
    """`requested`, lowered to half the files this process may open beside the backlogs in
    flight, so connections alone cannot exhaust them."""
    soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft == resource.RLIM_INFINITY:
        return requested
    return max(1, min(requested, (soft - IN_FLIGHT_BACKLOGS * BACKLOG) // 2))


class BoundedSite(web.BaseSite):
    """A TCP site with at most `limit` open connections: admitting one past it closes the
    oldest connection not answering a request (`answering(handler)` says which are), else the
    oldest of all (a request still being read is bounded by the read time-out anyway)."""

    def __init__(self, runner: web.AppRunner, host: str, port: int, limit: int,
                 answering: Callable[[web.RequestHandler], bool]):
        super().__init__(runner)
        self._host, self._port, self._limit, self._answering = host, port, limit, answering

    @property
    def name(self) -> str:
        return f"http://{self._host}:{self._port}"

    def _admit(self) -> web.RequestHandler:
        handler = self._runner.server()
        # After the connections accepted before it have registered with the server (asyncio
        # attaches a socket to its handler in a callback queued behind this one).
        asyncio.get_running_loop().call_soon(self._make_room, handler)
        return handler

    def _make_room(self, newcomer: web.RequestHandler) -> None:
        others = [c for c in self._runner.server.connections if c is not newcomer]
        excess = len(others) + 1 - self._limit
        for old in sorted(others, key=self._answering)[:max(excess, 0)]:  # stable: oldest first
            old.force_close()

    async def start(self) -> None:
        await super().start()
        self._server = await asyncio.get_running_loop().create_server(
            self._admit, self._host, self._port, backlog=BACKLOG)


class RateLimit(logging.Filter):
    """Passes at most `burst` records per `period` seconds; the first record let through after
    some were dropped says how many."""

    def __init__(self, burst: int = 5, period: float = 60.0):
        super().__init__()
        self.burst, self.period = burst, period
        self._window_start, self._passed, self._dropped = -period, 0, 0

    def filter(self, record: logging.LogRecord) -> bool:
        now = time.monotonic()
        if now - self._window_start >= self.period:
            self._window_start, self._passed = now, 0
        if self._passed >= self.burst:
            self._dropped += 1
            return False
        self._passed += 1
        if self._dropped:
            record.msg = f"[{self._dropped} similar messages not logged] {record.msg}"
            self._dropped = 0
        return True


def limit_logs(burst: int = 5, period: float = 60.0) -> None:
    """Rate-limit each of `NOISY_LOGGERS` (once per process; later calls change nothing)."""
    for name in NOISY_LOGGERS:
        logger = logging.getLogger(name)
        if not any(isinstance(f, RateLimit) for f in logger.filters):
            logger.addFilter(RateLimit(burst, period))
