"""Remote agents over the 2018 competition's HTTP protocol: our arena plays the runner.

A policy file of kind "http" says where the agents listen (see `rllib_pommer.serving` for the
protocol); the kind is a plugin of the registry (`registry.KINDS`), so this module and `requests`
load only when such an agent is first built:

    kind = "http"
    description = "Skynet's 2018 container"
    host = "127.0.0.1"        # the default
    port = [10080, 10081]     # one port, or a list of 1, 2 or 4
    timeout = 0.15            # seconds per /action; the default is the competition's

Each server is one agent playing one seat, but our arena puts a policy on both seats of a team, so
the seats 0..3 are split evenly over the listed ports: one port serves every seat (enough when a
policy plays one seat), two ports serve seats {0, 1} and {2, 3} (a team's two members, {0, 2} or
{1, 3}, always reach different servers), four ports one seat each.

As in the competition, an /action that times out or cannot connect is played as Stop. Anything
else a remote agent gets wrong (an HTTP error, an answer that is not JSON, an action that is not an
integer 0..5) raises a ValueError naming the address, the seat and the answer: that is a broken
agent, not a slow one, and playing Stop instead would silently bias the results it is measured by.

In a TeamRadio game (game type 3, as in the 2019 competition) the agent takes part in the channel
of `speaker.radio_act`: what it hears goes out as the observation's `message`, and the server
may answer a plain move (silence) or `[move, word, word]` with words 0..7; anything else is an
error as above. A timed-out turn is Stop and silence.

Every game starts with /init_agent, carrying our optional `seed`: the state of the seat's
Generator, so one of our policies served by `python -m rllib_pommer.serve` plays exactly as it
would in process. No /episode_end is sent: the Agent protocol has no end-of-game call.

A server plays one seat of one game at a time, and the protocol's /action does not say which game
an observation belongs to. So an agent whose server has since been seated by another HttpAgent (of
another seat, or of another game played in lockstep) refuses to act, instead of feeding that
server two games' observations; across processes this cannot be seen, so use one worker.
"""

from __future__ import annotations

import json
import logging
import weakref
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import requests

from ..game.constants import (
    NUM_ACTIONS,
    NUM_AGENTS,
    RADIO_NUM_WORDS,
    RADIO_VOCAB_SIZE,
    Action,
    has_radio,
)
from ..game.observation import Observation
from ..game.serialize import dump_observation, load_words
from .registry import PolicySpec, register_kind
from .speaker import SILENCE

DEFAULT_HOST = "127.0.0.1"
DEFAULT_TIMEOUT = 0.15  # the competition runner's wait for an action
INIT_TIMEOUT = 10.0  # /init_agent may load a model; only /action is held to the game's pace
ACTION_SPACE = "6"  # Discrete(6), JSON-encoded as the competition's runner sent it
PARAMS = ("host", "port", "timeout")

logger = logging.getLogger(__name__)

# host:port -> the HttpAgent that last seated that server, i.e. whose game it is playing.
_SEATED_BY: weakref.WeakValueDictionary[str, HttpAgent] = weakref.WeakValueDictionary()


def _ports(value: Any, where: str) -> tuple[int, ...]:
    ports = tuple(value) if isinstance(value, list) else (value,)
    if len(ports) not in (1, 2, 4) or not all(
        isinstance(p, int) and not isinstance(p, bool) and 0 < p < 65536 for p in ports
    ):
        raise ValueError(f"{where}: port must be a port number or a list of 1, 2 or 4 of them, "
                         f"got {value!r}")
    return ports


def _params(params: Mapping[str, Any], where: str) -> tuple[str, tuple[int, ...], float]:
    unknown = sorted(set(params) - set(PARAMS))
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {unknown} for kind 'http'; valid: {PARAMS}")
    if "port" not in params:
        raise ValueError(f"{where}: kind 'http' needs a port (or a list of ports)")
    host = params.get("host", DEFAULT_HOST)
    if not isinstance(host, str) or not host:
        raise ValueError(f"{where}: host must be a host name or address, got {host!r}")
    timeout = params.get("timeout", DEFAULT_TIMEOUT)
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or timeout <= 0:
        raise ValueError(f"{where}: timeout must be a positive number of seconds, got {timeout!r}")
    return host, _ports(params["port"], where), float(timeout)


class HttpAgent:
    """One seat played by a remote agent; `reset` picks the seat's server from `ports`."""

    def __init__(self, host: str, ports: Sequence[int], timeout: float = DEFAULT_TIMEOUT):
        self.host, self.ports, self.timeout = host, tuple(ports), timeout
        self.session = requests.Session()  # keep-alive: one connection per seat, not per step
        self.agent_id = -1
        self.address = ""  # host:port of the current seat's server
        self.radio = False  # a TeamRadio game: the message goes out, words may come back
        self.heard = self.said = SILENCE

    @classmethod
    def from_spec(cls, spec: PolicySpec) -> HttpAgent:
        return cls(*_params(spec.params, f"policy file {spec.path}"))

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        self.agent_id, self.radio = agent_id, has_radio(game_type)
        self.heard = self.said = SILENCE
        self.address = f"{self.host}:{self.ports[agent_id * len(self.ports) // NUM_AGENTS]}"
        body = {"id": json.dumps(agent_id), "game_type": json.dumps(game_type),
                "seed": json.dumps(rng.bit_generator.state)}
        try:
            response = self.session.post(self._url("init_agent"), json=body, timeout=INIT_TIMEOUT)
        except requests.RequestException as exc:
            raise ValueError(f"{self._who()} could not be seated: {exc}") from None
        self._answer(response, "init_agent")
        _SEATED_BY[self.address] = self

    def act(self, obs: Observation) -> int:
        if _SEATED_BY.get(self.address) is not self:
            raise ValueError(
                f"{self._who()} has since been seated by another seat or game: a server plays one "
                f"seat of one game at a time, so give each seat its own port and play the games "
                f"one after another")
        obs_dict = dump_observation(obs, self.heard if self.radio else None)
        body = {"obs": json.dumps(obs_dict), "action_space": ACTION_SPACE}
        self.said = SILENCE
        try:
            response = self.session.post(self._url("action"), json=body, timeout=self.timeout)
        except (requests.Timeout, requests.ConnectionError) as exc:
            logger.warning("%s gave no action at step %d (%s): playing Stop", self._who(),
                           int(obs.step_count), type(exc).__name__)
            return int(Action.STOP)
        answer = self._answer(response, "action")
        action = answer.get("action") if isinstance(answer, dict) else None
        if self.radio and isinstance(action, list):
            move, self.said = self._radio_action(action, response.text)
            return move
        if not _is_move(action):
            raise ValueError(f"{self._who()} answered /action with {response.text!r:.200}; "
                             f"expected {{\"action\": {self._expected()}}}")
        return action

    def hear(self, message) -> None:
        """TeamRadio: the teammate's last words, sent with the next observation."""
        self.heard = tuple(int(w) for w in message)

    def words(self) -> tuple[int, ...]:
        """TeamRadio: the words of the last answer (silence for a plain move or none)."""
        return self.said

    def _radio_action(self, action: list, text: str) -> tuple[int, tuple[int, ...]]:
        """A TeamRadio answer's [move, word, word], checked."""
        try:
            if len(action) != 1 + RADIO_NUM_WORDS or not _is_move(action[0]):
                raise ValueError("not [move, word, word]")
            return action[0], load_words(action[1:], "words")
        except ValueError as exc:
            raise ValueError(f"{self._who()} answered /action with {text!r:.200} ({exc}); "
                             f"expected {{\"action\": {self._expected()}}}") from None

    def _expected(self) -> str:
        move = f"<integer 0..{NUM_ACTIONS - 1}>"
        return f"{move} or [{move}, <word 0..{RADIO_VOCAB_SIZE - 1}>, <word>]" if self.radio \
            else move

    def _url(self, endpoint: str) -> str:
        return f"http://{self.address}/{endpoint}"

    def _who(self) -> str:
        return f"remote agent at {self.address} (agent {self.agent_id})"

    def _answer(self, response: requests.Response, endpoint: str) -> Any:
        if response.status_code != 200:
            raise ValueError(f"{self._who()} answered /{endpoint} with HTTP "
                             f"{response.status_code}: {response.text!r:.300}")
        try:
            return response.json()
        except ValueError:
            raise ValueError(f"{self._who()} answered /{endpoint} with {response.text!r:.200}, "
                             f"which is not JSON") from None


def _is_move(action: Any) -> bool:
    return isinstance(action, int) and not isinstance(action, bool) and 0 <= action < NUM_ACTIONS


register_kind("http", HttpAgent.from_spec)
