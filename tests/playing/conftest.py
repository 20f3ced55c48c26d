"""A played game's server under aiohttp's test client, and a page holding its seat."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from pathlib import Path

from aiohttp import ClientWebSocketResponse
from aiohttp.test_utils import TestClient, TestServer

from rllib_pommer.playing.server import TABLE, TOKEN_HEADER, Table, make_app
from rllib_pommer.playing.session import HumanGame, PlaySpec

from ..serving.conftest import serve  # noqa: F401  (the fixture: policies served on loopback)

SPEC = PlaySpec("simple", "static", seat=1, seed=3)
REPLY_TIMEOUT = 10  # seconds for any server message in these tests


def run_server(scenario: Callable[[TestClient, Table], Awaitable], out: Path,
               turn_time: float | None = None, spec: PlaySpec = SPEC, reconnect: float = 0.0):
    """Serve one game (turn time None: "wait"; a closed page forfeits after `reconnect`
    seconds) and run `scenario(client, table)` against it."""
    async def main():
        app = make_app(HumanGame(spec), out, turn_time, reconnect)
        async with TestClient(TestServer(app)) as client:
            return await scenario(client, app[TABLE])
    return asyncio.run(main())


class Seat:
    """A page holding the seat: its socket and the token its moves carry."""

    def __init__(self, client: TestClient, socket: ClientWebSocketResponse, token: str):
        self.client, self.socket, self.token = client, socket, token

    @classmethod
    async def take(cls, client: TestClient) -> Seat:
        socket = await client.ws_connect("/seat")
        hello = await socket.receive_json(timeout=REPLY_TIMEOUT)
        assert hello["type"] == "seated", hello
        return cls(client, socket, hello["token"])

    async def post(self, path: str, body, token: str | None = "mine"):
        headers = {TOKEN_HEADER: self.token if token == "mine" else token} if token else {}
        data = body if isinstance(body, bytes) else None
        response = await self.client.post(path, headers=headers, data=data,
                                          json=None if data is not None else body)
        return response.status, await response.json()

    async def next_message(self, kind: str = "frame") -> dict:
        """The next message of type `kind`, skipping others."""
        while True:
            message = await self.socket.receive_json(timeout=REPLY_TIMEOUT)
            if message["type"] == kind:
                return message

    async def move(self, action, step: int) -> dict:
        """Play `action` on `step` and return the frame of the next step."""
        status, answer = await self.post("/move", {"action": action, "step": step})
        assert status == 200, answer
        frame = await self.next_message()
        assert frame["step"] == step + 1
        return frame

    async def state(self) -> dict:
        return await (await self.client.get("/state")).json()
