"""One Team or TeamRadio game with a person on one seat and named policies on the other three.

The board and the agents' random streams come from `game_seeds(seed, 0)`, the arena's rule for
game 0 of a match seeded `seed`, so the same seed deals the same board as `evaluate --seed`. The
other seats are built by the arena's registry (`make_agent`), so any policy name works: scripted,
learned, a PPO run, or an `http` remote agent. The game is recorded as it is played, with every
agent's observations (the person's are what the page showed), in the schema `replay verify`,
`render` and `html` read; a game the person leaves early is recorded up to its last step and
marked as a forfeit, and one an agent broke off (see `stop`) as stopped.

In TeamRadio (`PlaySpec.variant` "radio") the agents play their turns through
`agents/speaker.radio_act`, hearing their teammates' last words (the person's, for the person's
teammate) and speaking if they do; the person sends the two words last set with `say` (silence
until then) with every move, and the view shows what the person hears and says.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

from ..agents.registry import make_agent
from ..agents.speaker import SILENCE, as_passed, radio_act
from ..game.constants import (
    NUM_ACTIONS,
    NUM_AGENTS,
    Action,
    GameConfig,
    Item,
    Result,
    has_radio,
    has_teams,
    preset,
    teammate_of,
)
from ..game.engine import Game
from ..game.records import GameRecorder
from ..game.seeding import game_seeds
from ..game.serialize import load_words
from ..viz.frames import Frame
from ..viz.page import action_labels, agent_stats, encode_frame

HUMAN = "human"


@dataclass(frozen=True)
class PlaySpec:
    """The person sits on `seat` of team `team`, whose other seat plays `teammate` (default: the
    `team` policy itself); both seats of the other team play `vs`; the game is the preset
    `variant`, "team" or "radio" (TeamRadio)."""

    team: str
    vs: str
    seat: int = 0
    teammate: str | None = None
    seed: int = 0
    variant: str = "team"

    def __post_init__(self):
        if isinstance(self.seat, bool) or self.seat not in range(NUM_AGENTS):
            raise ValueError(f"seat must be one of 0..{NUM_AGENTS - 1}, got {self.seat!r}")
        if not has_teams(self.config.game_type):
            raise ValueError(f"variant {self.variant!r}: play is a team game, 'team' or 'radio'")

    @property
    def config(self) -> GameConfig:
        return preset(self.variant)

    @property
    def partner_seat(self) -> int:
        return teammate_of(self.seat, self.config.game_type) - Item.AGENT0

    def players(self) -> list[str]:
        """Who plays each seat: `HUMAN` or a policy name."""
        return [HUMAN if s == self.seat else (self.teammate or self.team)
                if s == self.partner_seat else self.vs for s in range(NUM_AGENTS)]


def _one_torch_thread() -> None:
    """A learned seat decides one observation per step, where torch's intra-op threads cannot
    help and only spin against the server, many times slower than one thread on a loaded machine
    (docs/measurements.md). torch is only here if a learned policy was named."""
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(1)


class HumanGame:
    """The game: `advance(action)` plays the person's action and the agents' on the next step."""

    def __init__(self, spec: PlaySpec):
        self.spec = spec
        self.players = spec.players()
        self.agents = {s: make_agent(name) for s, name in enumerate(self.players)
                       if name != HUMAN}
        _one_torch_thread()
        board_seed, rngs = game_seeds(spec.seed, 0)
        self.game = Game(spec.config)
        self.radio = has_radio(spec.config.game_type)
        self.words = SILENCE  # what the person sends with each move (TeamRadio)
        self.obs = self.game.reset(board_seed)
        for seat, agent in self.agents.items():
            agent.reset(seat, int(spec.config.game_type), rngs[seat])
        self.recorder = GameRecorder(self.game.batch, 0, board_seed, " ".join(self.players))
        self.recorder.record.update(game=0, match_seed=spec.seed, human_seat=spec.seat,
                                    players=self.players)
        self.recorder.start()
        self.info: dict = {"result": int(Result.INCOMPLETE), "result_name": "Incomplete"}
        self.forfeit: dict | None = None
        self.stopped: dict | None = None

    @property
    def step(self) -> int:
        return len(self.recorder.record["steps"])

    @property
    def over(self) -> bool:
        return self.game.done or self.forfeit is not None or self.stopped is not None

    @property
    def human_alive(self) -> bool:
        return bool(self.game.batch.alive[0, self.spec.seat])

    def say(self, words) -> None:
        """TeamRadio: the two words 0..7 the person sends from the next step on."""
        if not self.radio:
            raise ValueError("words are sent in TeamRadio games only (play --variant radio)")
        self.words = load_words(words, "words")

    def advance(self, action: int) -> None:
        """One step: the person plays `action` (ignored once their agent is dead), with their
        words in TeamRadio; each living agent acts on its own observation."""
        if self.over:
            raise ValueError(f"the game is over (step {self.step}); no more moves")
        if isinstance(action, bool) or action not in range(NUM_ACTIONS):
            raise ValueError(f"action {action!r} is not one of 0..{NUM_ACTIONS - 1}")
        alive = self.game.batch.alive[0]
        actions: list = [int(Action.STOP)] * NUM_AGENTS
        if alive[self.spec.seat]:
            actions[self.spec.seat] = [int(action), *self.words] if self.radio else int(action)
        for seat, agent in self.agents.items():
            if alive[seat]:
                actions[seat] = self._turn(seat, agent)
        self.obs, _, _, self.info = self.game.step(actions)
        self.recorder.step(actions)

    def _turn(self, seat: int, agent) -> int | list[int]:
        """An agent's action on `seat`: its move, or in TeamRadio its turn as passed."""
        if not self.radio:
            return int(agent.act(self.obs.select(seat)))
        return as_passed(agent, radio_act(agent, self.obs.select(seat), self.game.message[seat]))

    def leave(self, reason: str) -> None:
        """The person left before the end: the game stops here, a forfeit of their seat."""
        if not self.over:
            self.forfeit = {"seat": self.spec.seat, "step": self.step, "reason": reason}

    def stop(self, reason: str) -> None:
        """An agent failed (a remote agent's malformed answer, say): the game stops unfinished."""
        if not self.over:
            self.stopped = {"step": self.step, "reason": reason}

    def result(self) -> str:
        """For the person's team: win, loss, tie, forfeit, or unfinished."""
        if self.forfeit:
            return "forfeit"
        if not self.game.done:
            return "unfinished"
        winners = self.info.get("winners", [])
        return "tie" if not winners else "win" if self.spec.seat in winners else "loss"

    def summary(self) -> str:
        """One line: the result for the person's team, why it ended early if it did, the
        steps played and the engine's result."""
        early = self.forfeit or self.stopped
        reason = f" ({early['reason']})" if early else ""
        winners = f", winners {self.info['winners']}" if self.info.get("winners") else ""
        return (f"{self.result()}{reason} after {self.step} steps; "
                f"{self.info['result_name']}{winners}")

    def _state(self) -> dict:
        steps = self.recorder.record["steps"]
        return steps[-1]["state"] if steps else self.recorder.record["initial_state"]

    def view(self) -> dict:
        """What the page shows now: the board through the person's fog, the agents' stats, the
        last actions, the step and the outcome."""
        seat, state = self.spec.seat, self._state()
        frame = Frame(self.step, np.asarray(self.obs.board[seat]),
                      np.asarray(self.obs.bomb_life[seat]), state["agents"], seat)
        steps = self.recorder.record["steps"]
        return {
            "step": self.step,
            "cells": encode_frame(frame),
            "agents": agent_stats(state["agents"]),
            "actions": action_labels(steps[-1]["actions"]) if steps else None,
            "radio": self._radio_view(state),
            "alive": self.human_alive,
            "over": self.over,
            "result": self.result(),
            "info": self.info,
            "forfeit": self.forfeit,
            "stopped": self.stopped,
        }

    def _radio_view(self, state: dict) -> dict | None:
        """TeamRadio: what the person hears (the teammate's last words), the words they send,
        and the last words of their team's two seats (the other team's are not heard)."""
        if not self.radio:
            return None
        team = (self.spec.seat, self.spec.partner_seat)
        return {"heard": [int(w) for w in self.game.message[self.spec.seat]],
                "saying": list(self.words),
                "words": [state["radio_from_agent"][s] if s in team else []
                          for s in range(NUM_AGENTS)]}

    def record(self) -> dict:
        """The game record so far (finished or not), with the person's result."""
        record = self.recorder.finish()
        record.update(human_result=self.result(), forfeit=self.forfeit, stopped=self.stopped)
        return record
