"""One agent of a named policy playing one seat of one game at a time, like a competition container.

The protocol carries no seed, so unless the caller sends our optional one, game k started by this
host draws its agent's randomness from `default_rng([seed, k])`: a restarted server with the same
`--seed` replays the same games when asked the same observations.

In a TeamRadio game the agent plays each turn through `agents/speaker.radio_act`: it hears the
observation's `message` and answers [move, word, word] (silence unless it speaks).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import NamedTuple

import numpy as np

from ..agents.registry import make_agent
from ..agents.speaker import radio_act
from ..game.constants import NUM_AGENTS, RADIO_PRESET, TEAM_PRESET, has_radio
from ..game.engine import Game
from ..game.observation import Observation
from .protocol import BadRequest


class Seat(NamedTuple):
    """The seat a server plays in the current game."""
    agent_id: int
    game_type: int


class PolicyHost:
    """One agent of a named policy, playing the seat the last `/init_agent` gave it."""
    def __init__(self, policy: str, filters: Iterable[str] = (), seed: int = 0):
        self.agent = make_agent(policy, filters)
        self.seed = seed
        self.games_started = 0
        self.seat: Seat | None = None  # set by the first /init_agent

    def warm_up(self, steps: int = 5) -> None:
        """Play a few steps of a throwaway Team game and a throwaway TeamRadio game on every
        seat, so compiled kernels (numba, on a fresh install; TeamRadio steps words through
        kernels of their own) and the first forward passes run now, not in the first real move
        (which the competition's runner gives 0.15 s); then forget those games. The seeding of
        real games is unchanged."""
        for preset in (TEAM_PRESET, RADIO_PRESET):
            game = Game(preset)
            radio = has_radio(preset.game_type)
            for agent_id in range(NUM_AGENTS):
                obs = game.reset(agent_id)
                self.agent.reset(agent_id, preset.game_type, np.random.default_rng(0))
                for _ in range(steps):
                    heard = game.message[agent_id].tolist() if radio else None
                    actions: list = [0] * NUM_AGENTS
                    actions[agent_id] = self.act(obs.select(agent_id), heard)
                    obs, _, done, _ = game.step(actions)
                    if done:
                        break
        self.seat = None
        self.games_started = 0

    def start_game(self, seat: Seat, rng: np.random.Generator | None = None) -> None:
        """Reset the agent for a new game on `seat`, with `rng` or the host's next game seed."""
        if rng is None:
            rng = np.random.default_rng([self.seed, self.games_started])
        self.games_started += 1
        self.seat = seat
        self.agent.reset(seat.agent_id, seat.game_type, rng)

    def seated(self, endpoint: str) -> Seat:
        """The seat being played; `endpoint` names the request that needs one."""
        if self.seat is None:
            raise BadRequest(f"{endpoint} before /init_agent: no game is being played")
        return self.seat

    def act(self, obs: Observation, message: Sequence[int] | None = None) -> int | list[int]:
        """The agent's move; in TeamRadio (`message`: the words it hears) [move, word, word]."""
        if message is None:
            return int(self.agent.act(obs))
        return list(radio_act(self.agent, obs, message))

    def end_game(self) -> None:
        """The competition's runner seated its agents once and ended every game with
        /episode_end, so the next game on the same seat starts here."""
        self.start_game(self.seated("/episode_end"))
