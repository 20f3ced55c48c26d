"""One seat of the Team game as a single-agent Gymnasium env, `rllib_pommer/PommeTeam-v0`.

    env = gymnasium.make("rllib_pommer/PommeTeam-v0", teammate="simple", opponents="static")

The agent being trained sits in `seat`; named policies play the other three (anything the arena's
registry resolves, `agents/registry.py`: a name in `policies/`, optionally with a filter suffix,
a policy file's path, or a PPO run folder): `teammate` across the board, `opponents` (one name
for both, or two, in seat order) beside it. All three default to SimpleAgent. Each reset draws
the board and the three agents' random streams from the env's seeded generator, so `reset(seed=s)`
followed by the same actions replays the same episode.

The episode ends when the trained agent leaves the game (it dies, or the game ends); its reward is
zero until then and the `reward` mode's at that step (`game/rewards.py`: "shaped" as in the
paper, or "raw"). Observations are the 19 planes as a Box by default (`observation` picks another
form, `team.OBSERVATIONS`).

`game="radio"` plays TeamRadio (also registered as `rllib_pommer/PommeRadio-v0`): the trained
agent's action is [move, word, word] (`MultiDiscrete([6, 8, 8])`) and it observes its teammate's
words (`team.py`); the named policies on the other seats play their turns through
`agents/speaker.radio_act`: they hear their teammates' words (the trained agent's, for the seat
across) and send (0, 0) unless they speak (a `_words` name, a radio network).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from copy import deepcopy

import gymnasium as gym

from ..agents.registry import make_agent
from ..agents.speaker import as_passed, radio_act
from ..game.constants import MAX_STEPS, NUM_AGENTS
from .team import RENDER_MODES, MultiAgentTeam, check_action, check_render_mode

ENV_ID = "rllib_pommer/PommeTeam-v0"
RADIO_ENV_ID = "rllib_pommer/PommeRadio-v0"  # the same env with game="radio"


class PommeTeamEnv(gym.Env):
    """One trained seat of the Team game against three named policies (module docstring)."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 8}

    def __init__(self, render_mode: str | None = None, *, seat: int = 0,
                 teammate: str | os.PathLike = "simple",
                 opponents: str | os.PathLike | Sequence[str | os.PathLike] = "simple",
                 reward: str = "shaped", observation: str = "planes", max_steps: int = MAX_STEPS,
                 game: str = "team"):
        self.render_mode = check_render_mode(render_mode)
        if seat not in range(NUM_AGENTS):
            raise ValueError(f"seat {seat!r} is not one of 0..{NUM_AGENTS - 1}")
        if isinstance(opponents, (str, os.PathLike)):
            opponents = (opponents, opponents)
        if len(opponents) != 2:
            raise ValueError(f"opponents: one policy or two, got {len(opponents)}: {opponents!r}")
        self.seat = seat
        policies = {(seat + 2) % NUM_AGENTS: teammate, (seat + 1) % NUM_AGENTS: opponents[0],
                    (seat + 3) % NUM_AGENTS: opponents[1]}
        self.others = {s: make_agent(policies[s]) for s in sorted(policies)}
        self.team = MultiAgentTeam({"reward": reward, "observation": observation,
                                    "max_steps": max_steps, "game": game})
        self.observation_space = deepcopy(self.team.observation_spaces[seat])
        self.action_space = deepcopy(self.team.agent_action_space)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        obs, infos = self.team.reset(seed=int(self.np_random.integers(2**63)))
        for (s, agent), rng in zip(self.others.items(), self.np_random.spawn(len(self.others)),
                                   strict=True):
            agent.reset(s, int(self.team.game.config.game_type), rng)
        return obs[self.seat], infos[self.seat]

    def step(self, action):
        if self.seat not in self.team.agents:
            raise ValueError("step: the trained agent's episode is over; call reset()")
        rows, heard = self.team.last_observation, self.team.game.message
        actions = {self.seat: check_action(action, self.seat, self.team.radio)}  # before the others
        for s, agent in self.others.items():
            if s in self.team.agents:
                actions[s] = as_passed(agent, radio_act(agent, rows.select(s), heard[s])) \
                    if self.team.radio else agent.act(rows.select(s))
        obs, rewards, terminateds, _, infos = self.team.step(actions)
        return obs[self.seat], rewards[self.seat], terminateds[self.seat], False, infos[self.seat]

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() without a render_mode: pass render_mode='rgb_array'")
            return None
        return self.team.draw()
