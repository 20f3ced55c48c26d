"""The web side of a played game: the page, its moves, the turn clock, one page per game.

    GET  /          the page (409 once the game is over)
    GET  /seat      WebSocket: the page holding it holds the seat. The server sends
                    {"type": "seated", "token": ...} and then every step's view; the page sends
                    nothing. A page that closes before the end (a reload, the tab closed)
                    frees the seat and pauses the clock; a page that takes the seat within
                    the reconnect time (`RECONNECT`, `play --reconnect`) goes on with the
                    game, else it is forfeited. While a page holds the seat, another gets
                    {"type": "refused", "error": ...} and is closed.
    POST /move      {"action": 0..5 or "stop|up|down|left|right|bomb", "step": T}, with the
                    seat's token in the X-Seat-Token header: the person's action for step T
    POST /words     {"words": [w1, w2]} (TeamRadio, each 0..7), token too: the words the person
                    sends with every move from the next step on
    POST /settings  {"turn_time": seconds or "wait", "paused": true|false} (either key), token too
    GET  /state     the game so far, as JSON (step, every step's actions, result, settings)

Malformed moves, words and settings get 400 naming the field and value, a request without the seat's
token 403, a move that cannot be played now 409 (another step, paused, a dead agent, the game over;
so do words in a Team game); none of them touches the game. The clock plays a step as soon as the
person moves, or with Stop when the turn time runs out ("wait": never); it starts when a page takes
the seat and stops while paused. Once the person's agent is dead the others play on at the turn time
(`WATCH_STEP` under "wait"). When the game ends, by a result, a forfeit or an agent failing (a
remote agent's malformed answer, say), the replay is written and `done` set. Agents act in a worker
thread, so a slow remote agent never stalls the page's requests.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import os
import secrets
import signal
import tempfile
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

from aiohttp import WSCloseCode, web

from ..game.constants import NUM_ACTIONS, Action
from ..game.records import write_games
from ..serving.app import start
from ..serving.protocol import BadRequest, parse_body
from ..viz.page import board_assets, page_html
from .session import HUMAN, HumanGame

WAIT = "wait"
TURN_TIME_RANGE = (0.05, 60.0)  # seconds
WATCH_STEP = 0.2  # seconds per step once the person is dead and the turn time is "wait"
HEARTBEAT = 10.0  # seconds: a page gone without closing its socket is noticed within this
RECONNECT = 30.0  # seconds a closed page has to come back (a reload) before the game is forfeited
HANDOVER = 2.0  # seconds a new page waits for the one holding the seat to close (a reload's
# new page asks before the old one's socket has closed)
MAX_BODY_BYTES = 4 * 1024  # a move is a few dozen bytes
TOKEN_HEADER = "X-Seat-Token"
MOVE_NAMES = {action.name.lower(): int(action) for action in Action}

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


class Refused(Exception):
    """A request the game cannot take: answered with `status` and `{"error": message}`."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status = status


def _fields(body: dict, allowed: tuple[str, ...], what: str) -> None:
    unknown = sorted(set(body) - set(allowed))
    if unknown:
        raise BadRequest(f"{what}: unknown field {unknown[0]!r}; valid: {list(allowed)}")


def parse_move(body: Any) -> tuple[int, int]:
    """(action, step) of a move body, or BadRequest naming what is wrong."""
    _fields(body, ("action", "step"), "move")
    for key in ("action", "step"):
        if key not in body:
            raise BadRequest(f'move: missing field {key!r}, e.g. {{"action": "up", "step": 3}}')
    action, step = body["action"], body["step"]
    if isinstance(action, str) and action.lower() in MOVE_NAMES:
        action = MOVE_NAMES[action.lower()]
    elif isinstance(action, bool) or not isinstance(action, int) or action not in range(
            NUM_ACTIONS):
        raise BadRequest(f"move: action {json.dumps(action):.60} is not one of "
                         f"0..{NUM_ACTIONS - 1} or {'/'.join(MOVE_NAMES)}")
    if isinstance(step, bool) or not isinstance(step, int) or step < 0:
        raise BadRequest(f"move: step {json.dumps(step):.60} is not a step number (0, 1, ...)")
    return action, step


def parse_words(body: Any) -> list:
    """The `words` of a words body (checked by the game: `HumanGame.say`)."""
    _fields(body, ("words",), "words")
    if "words" not in body:
        raise BadRequest('words: missing field \'words\', e.g. {"words": [3, 5]}')
    return body["words"]


def parse_turn_time(value: Any) -> float | None:
    """Seconds per turn, or None for "wait" (the clock waits for the person)."""
    if value == WAIT:
        return None
    lo, hi = TURN_TIME_RANGE
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(
            value) or not lo <= value <= hi:
        raise ValueError(f"turn time {json.dumps(value):.60} is neither a number of seconds in "
                         f"{lo}..{hi} nor {WAIT!r}")
    return float(value)


def parse_settings(body: Any) -> dict:
    """The settings a body changes: `turn_time` (seconds or None) and/or `paused`."""
    _fields(body, ("turn_time", "paused"), "settings")
    changes: dict = {}
    if "turn_time" in body:
        try:
            changes["turn_time"] = parse_turn_time(body["turn_time"])
        except ValueError as exc:
            raise BadRequest(f"settings: {exc}") from None
    if "paused" in body:
        if not isinstance(body["paused"], bool):
            raise BadRequest(f"settings: paused must be true or false, got "
                             f"{json.dumps(body['paused']):.60}")
        changes["paused"] = body["paused"]
    return changes


class Table:
    """A game being played: the game itself, the page holding the seat, the clock's settings.

    Only the clock (`run`) changes the game; request handlers leave a move or a change of
    settings and wake it."""

    def __init__(self, game: HumanGame, out: Path, turn_time: float | None,
                 reconnect: float = RECONNECT):
        self.game = game
        self.out = out
        self.turn_time = turn_time
        self.reconnect = reconnect
        self.paused = False
        self.page: web.WebSocketResponse | None = None
        self.token: str | None = None
        self.move: int | None = None  # the person's action for the current step, once sent
        self.busy = False  # a step is being played
        self.left: str | None = None  # why the person left for good, if they did
        self.away_until: float | None = None  # while no page holds the seat: the loop time
        # by which one must take it, or the game is forfeited
        self.seat_free = asyncio.Event()  # no page holds the seat
        self.seat_free.set()
        self.wake = asyncio.Event()
        self.seated = asyncio.Event()
        self.done = asyncio.Event()
        self.saved: Path | None = None
        self.errors: list[str] = []  # what went wrong besides the game: a failed agent or write

    def settings(self) -> dict:
        return {"turnTime": self.turn_time, "paused": self.paused}

    def ended(self) -> str | None:
        """Why no page can be served any more, if none can."""
        if self.game.over or self.left:
            return "this game is over; start the command again for a new one"
        return None

    def refusal(self) -> str | None:
        """Why a new page cannot take the seat, if it cannot."""
        if self.page is None:
            return self.ended()
        return self.ended() or "this game is already being played in another page"

    async def refusal_after_handover(self) -> str | None:
        """`refusal()`, once the page holding the seat has had `HANDOVER` seconds to close."""
        if self.page is not None and not self.ended():
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(self.seat_free.wait(), HANDOVER)
        return self.refusal()

    def take_seat(self, page: web.WebSocketResponse) -> str:
        """`page` holds the seat from now on: the token its requests must carry."""
        self.page, self.token, self.away_until = page, secrets.token_urlsafe(16), None
        self.seat_free.clear()
        self.seated.set()
        self.wake.set()  # a page back after leaving: the clock goes on
        return self.token

    def page_closed(self, page: web.WebSocketResponse) -> None:
        """The page holding the seat closed: the seat is free for `reconnect` seconds."""
        if self.page is page and not self.game.over:
            self.page, self.token = None, None
            self.seat_free.set()
            self.away_until = asyncio.get_running_loop().time() + self.reconnect
            self.wake.set()

    def check_token(self, request: web.Request) -> None:
        token = request.headers.get(TOKEN_HEADER)
        if self.token is None or token is None or not secrets.compare_digest(token, self.token):
            raise Refused(403, f"this page does not hold the seat (missing or wrong "
                               f"{TOKEN_HEADER} header)")

    def take_move(self, action: int, step: int) -> None:
        game = self.game
        if game.over:
            raise Refused(409, f"the game is over (step {game.step}); no more moves")
        if self.paused:
            raise Refused(409, "the game is paused; resume it to move")
        if not game.human_alive:
            raise Refused(409, f"your agent (agent {game.spec.seat}) is dead; the others play on")
        if self.busy or step != game.step:
            raise Refused(409, f"move for step {step}, but the game is at step {game.step}"
                               + (" (being played)" if self.busy else ""))
        if self.move is not None:
            raise Refused(409, f"step {step} already has your move "
                               f"({Action(self.move).name.lower()})")
        self.move = action
        self.wake.set()

    def take_words(self, words: list) -> None:
        """The person's words for the steps to come; a step being played may already take them."""
        if self.game.over:
            raise Refused(409, f"the game is over (step {self.game.step}); no more words")
        if not self.game.radio:
            raise Refused(409, "this is a Team game: words are sent in TeamRadio only "
                               "(play --variant radio)")
        try:
            self.game.say(words)
        except ValueError as exc:
            raise BadRequest(str(exc)) from None

    def change(self, changes: dict) -> None:
        """New settings; a new turn time or a resume restarts the current turn's clock."""
        self.turn_time = changes.get("turn_time", self.turn_time)
        self.paused = changes.get("paused", self.paused)
        self.wake.set()

    def turn_timeout(self) -> float | None:
        """Seconds the clock waits for the current step; None: until woken."""
        if self.away_until is not None:
            return max(0.0, self.away_until - asyncio.get_running_loop().time())
        if self.paused:
            return None
        if not self.game.human_alive:
            return self.turn_time or WATCH_STEP
        return self.turn_time

    async def send(self, message: dict) -> None:
        if self.page is not None and not self.page.closed:
            # A page going away is noticed by its handler, which ends the game.
            with contextlib.suppress(ConnectionError, RuntimeError):
                await self.page.send_json(message)

    async def run(self) -> None:
        """The clock: one step per move or per turn time, until the game ends; then the
        replay is saved and the page told."""
        await self.seated.wait()
        while True:
            if self.away_until is not None and (
                    asyncio.get_running_loop().time() >= self.away_until):
                self.left = "the page was closed"
            if self.left:
                self.game.leave(self.left)
            if self.game.over:
                break
            if self.move is None or self.paused or self.away_until is not None:
                try:
                    await asyncio.wait_for(self.wake.wait(), self.turn_timeout())
                    woken = True
                except asyncio.TimeoutError:
                    woken = False
                self.wake.clear()
                if (self.left or self.paused or self.away_until is not None
                        or (woken and self.move is None)):
                    continue  # left, paused, away, or the settings changed: a fresh turn
            action = int(Action.STOP) if self.move is None else self.move
            self.busy = True
            try:
                await asyncio.to_thread(self.game.advance, action)
            except Exception as exc:  # a failing agent ends the game, which is still saved
                self.errors.append(f"the game stopped at step {self.game.step}: {exc}")
                self.game.stop(str(exc))
            finally:
                self.busy, self.move = False, None
            await self.send({"type": "frame", **self.game.view(), **self.settings()})
        await self._finish()

    async def _finish(self) -> None:
        record = self.game.record()
        try:
            await asyncio.to_thread(write_games, self.out, [record])
            self.saved = self.out
        except OSError as exc:  # a full disk, a folder gone: the game goes to a fallback file
            self.saved = await asyncio.to_thread(_write_fallback, self.out, record)
            kept = f"saved it to {self.saved} instead" if self.saved else "no fallback either"
            self.errors.append(f"could not write the replay to {self.out} ({exc}); {kept}")
        await self.send({"type": "over", **self.game.view(), **self.settings(),
                          "replay": str(self.saved) if self.saved else None,
                          "error": "; ".join(self.errors) or None})
        if self.page is not None:
            await self.page.close()
        self.done.set()

    def state(self) -> dict:
        record = self.game.recorder.record
        return {"seat": self.game.spec.seat, "players": self.game.players,
                "step": self.game.step, "actions": [s["actions"] for s in record["steps"]],
                **({"full_actions": [s["full_actions"] for s in record["steps"]]}
                   if self.game.radio else {}),
                "over": self.game.over, "result": self.game.result(),
                "forfeit": self.game.forfeit, "stopped": self.game.stopped, **self.settings(),
                "replay": str(self.saved) if self.saved else None}


def _write_fallback(out: Path, record: dict) -> Path | None:
    """The replay written to a new file in the system's temporary folder, named after `out`,
    when `out` could not be written; None if that fails too."""
    name = out.name or "play.jsonl.gz"
    suffix = ".jsonl.gz" if name.endswith(".gz") else ".jsonl"
    try:
        handle, path = tempfile.mkstemp(prefix=f"{name.split('.')[0]}-", suffix=suffix)
        os.close(handle)
        write_games(path, [record])
    except OSError:
        return None
    return Path(path)


TABLE = web.AppKey("table", Table)


@web.middleware
async def _refusals_as_json(request: web.Request, handler: Handler) -> web.StreamResponse:
    try:
        return await handler(request)
    except BadRequest as exc:
        return web.json_response({"error": str(exc)}, status=400)
    except Refused as exc:
        return web.json_response({"error": str(exc)}, status=exc.status)


def _page_data(table: Table) -> dict:
    game = table.game
    spec = game.spec
    players = ["you" if p == HUMAN else p for p in game.players]
    partner = players[spec.partner_seat]
    radio = "TeamRadio: " if game.radio else ""
    return {
        "title": f"{radio}You (agent {spec.seat}) and {partner} against {spec.vs} · "
                 f"seed {spec.seed}",
        "board": board_assets(game.game.config.board_size),
        "players": players,
        "radio": game.radio,
    }


async def page(request: web.Request) -> web.Response:
    table = request.app[TABLE]
    # Served while another page holds the seat, which its socket then asks for: a reload's
    # old page closes only once the new one has arrived.
    reason = table.ended()
    if reason:
        return web.Response(status=409, text=f"Refused: {reason}.\n")
    return web.Response(text=page_html(__package__, "play.html", _page_data(table)),
                        content_type="text/html")


async def seat(request: web.Request) -> web.WebSocketResponse:
    table = request.app[TABLE]
    socket = web.WebSocketResponse(heartbeat=HEARTBEAT)
    await socket.prepare(request)
    reason = await table.refusal_after_handover()
    if reason:
        await socket.send_json({"type": "refused", "error": reason})
        await socket.close(code=WSCloseCode.POLICY_VIOLATION, message=b"refused")
        return socket
    token = table.take_seat(socket)
    await socket.send_json({"type": "seated", "token": token, **table.game.view(),
                            **table.settings()})
    async for _ in socket:
        pass  # the page sends nothing: what matters is that it stays
    table.page_closed(socket)
    return socket


async def move(request: web.Request) -> web.Response:
    table = request.app[TABLE]
    table.check_token(request)
    action, step = parse_move(parse_body(await request.read()))
    table.take_move(action, step)
    return web.json_response({"accepted": {"action": Action(action).name.lower(), "step": step}})


async def words(request: web.Request) -> web.Response:
    table = request.app[TABLE]
    table.check_token(request)
    table.take_words(parse_words(parse_body(await request.read())))
    return web.json_response({"saying": list(table.game.words)})


async def settings(request: web.Request) -> web.Response:
    table = request.app[TABLE]
    table.check_token(request)
    table.change(parse_settings(parse_body(await request.read())))
    await table.send({"type": "settings", **table.settings()})
    return web.json_response(table.settings())


async def state(request: web.Request) -> web.Response:
    return web.json_response(request.app[TABLE].state())


async def _clock(app: web.Application):
    """Runs the game's clock for the application's lifetime."""
    task = asyncio.create_task(app[TABLE].run())
    yield
    task.cancel()


def make_app(game: HumanGame, out: Path, turn_time: float | None,
             reconnect: float = RECONNECT) -> web.Application:
    app = web.Application(client_max_size=MAX_BODY_BYTES, middlewares=[_refusals_as_json])
    app[TABLE] = Table(game, out, turn_time, reconnect)
    app.cleanup_ctx.append(_clock)
    app.router.add_get("/", page)
    app.router.add_get("/seat", seat)
    app.router.add_post("/move", move)
    app.router.add_post("/words", words)
    app.router.add_post("/settings", settings)
    app.router.add_get("/state", state)
    return app


async def serve_game(app: web.Application, host: str, port: int,
                     on_ready: Callable[[int], None]) -> Table:
    """Serve until the game ends (or SIGINT/SIGTERM, which forfeits it); the replay is saved
    either way. `on_ready` gets the bound port."""
    table = app[TABLE]
    runner, bound_port = await start(app, host, port)  # the agent server's time-outs and limits
    loop = asyncio.get_running_loop()

    def stop() -> None:
        table.left = "the server was stopped"
        table.seated.set()  # a game nobody took is recorded too
        table.wake.set()

    for signum in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(signum, stop)
    try:
        on_ready(bound_port)
        await table.done.wait()
    finally:
        await runner.cleanup()
    return table
