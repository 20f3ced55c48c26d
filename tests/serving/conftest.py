"""Servers on free loopback ports, each on its own event loop in a background thread."""

from __future__ import annotations

import asyncio
import json
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from aiohttp import web

from rllib_pommer.game.constants import TEAM_PRESET, GameConfig
from rllib_pommer.game.engine import Game
from rllib_pommer.game.observation import Observation
from rllib_pommer.game.serialize import dump_observation
from rllib_pommer.serving.app import make_app, start
from rllib_pommer.serving.policy_host import PolicyHost


@contextmanager
def running(app: web.Application, **start_options) -> Iterator[int]:
    """Serve `app` on 127.0.0.1 until the block ends (`start_options` go to `start`); yields
    the port."""
    loop = asyncio.new_event_loop()
    runner, port = loop.run_until_complete(start(app, "127.0.0.1", 0, **start_options))
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    try:
        yield port
    finally:
        asyncio.run_coroutine_threadsafe(runner.cleanup(), loop).result(timeout=10)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(timeout=10)
        loop.close()


@pytest.fixture
def serve() -> Iterator[Callable[..., int]]:
    """`serve(app)` or `serve(policy, filters=..., seed=...)`: the port of a running server."""
    with ExitStack() as stack:
        def start_one(app_or_policy, filters=(), seed=0) -> int:
            app = app_or_policy
            if isinstance(app_or_policy, str):
                app = make_app(PolicyHost(app_or_policy, filters, seed))
            return stack.enter_context(running(app))

        yield start_one


def http_policy(folder: Path, ports: list[int], timeout: float = 0.15) -> Path:
    path = folder / "remote.toml"
    path.write_text(f'kind = "http"\ndescription = "test"\nport = {ports}\ntimeout = {timeout}\n')
    return path


def team_observations(seat: int, steps: int, seed: int = 3,
                      config: GameConfig = TEAM_PRESET) -> list[Observation]:
    """`seat`'s observations over the first `steps` steps of a game (Team, or `config`) of
    random moves."""
    game, rng = Game(config), np.random.default_rng(seed)
    obs = game.reset(seed)
    seen = []
    for _ in range(steps):
        seen.append(obs.select(seat))
        obs, _, done, _ = game.step(rng.integers(0, 5, size=4))
        if done:
            break
    return seen


def obs_text(obs: Observation) -> str:
    """The observation as the runner's /action sends it."""
    return json.dumps(dump_observation(obs))


def games_played(records: Sequence) -> list:
    """Match records without the names of the policies (a served policy is named by its
    `remote.toml`): what was played, to compare with the same match played in process."""
    return [replace(record, team="", vs="") for record in records]
