"""The four-agent Team game as a PettingZoo `ParallelEnv`, for tools that speak PettingZoo.

Same game, observations, rewards and seeding as the RLlib env (both are `team.MultiAgentTeam`);
agents are named "player_0".."player_3" (PettingZoo convention), and an agent that dies leaves
`agents` after its last step, as in PettingZoo's parallel API. As there, `step` takes an action for
every live agent and no other: a missing, unknown or departed agent, a step before `reset`, an
action outside the action space or an unknown config key is a ValueError naming it.
Observations default to the 19 planes as a Box (config `observation` picks another form,
`team.OBSERVATIONS`). Config `game = "radio"` plays TeamRadio: actions [move, word, word]
(`MultiDiscrete([6, 8, 8])`) and the teammate's words in every observation (`team.py`).
"""

from __future__ import annotations

from copy import deepcopy

import gymnasium as gym
from pettingzoo import ParallelEnv

from .team import (
    CONFIG_KEYS,
    RENDER_MODES,
    MultiAgentTeam,
    check_action,
    check_render_mode,
)


def _name(agent: int) -> str:
    return f"player_{agent}"


class PommeParallelEnv(ParallelEnv):
    """The Team game as a PettingZoo `ParallelEnv` (agents "player_0".."player_3").

    config: as `team.MultiAgentTeam`'s, with observation "planes" by default; render_mode None or
    "rgb_array" (the whole board, drawn by the replay renderer).
    """

    metadata = {"name": "pommerman_team_v0", "render_modes": RENDER_MODES, "render_fps": 8}

    def __init__(self, config: dict | None = None, render_mode: str | None = None):
        self.render_mode = check_render_mode(render_mode)
        unknown = sorted(set(config or {}) - set(CONFIG_KEYS))
        if unknown:
            raise ValueError(f"unknown config key(s) {unknown}; valid: {list(CONFIG_KEYS)}")
        self.env = MultiAgentTeam({"observation": "planes", **(config or {})})
        self.possible_agents = [_name(a) for a in self.env.possible_agents]
        self._ids = {_name(a): a for a in self.env.possible_agents}
        self.agents = []
        # Own space objects per agent, so seeding one agent's space never moves another's.
        self._observation_spaces = {n: deepcopy(self.env.observation_spaces[self._ids[n]])
                                    for n in self.possible_agents}
        self._action_spaces = {n: deepcopy(self.env.agent_action_space)
                               for n in self.possible_agents}

    def observation_space(self, agent):
        return self._observation_spaces[agent]

    def action_space(self, agent):
        return self._action_spaces[agent]

    def reset(self, seed=None, options=None):
        obs, infos = self.env.reset(seed=seed, options=options)
        self.agents = [_name(a) for a in self.env.agents]
        return self._named(obs), self._named(infos)

    def step(self, actions):
        if not self.agents:
            raise ValueError("step: no live agents (call reset() first, or again after the "
                             "episode ended)")
        unknown = [name for name in actions if name not in self.agents]
        if unknown:
            what = "not live (left the game)" if unknown[0] in self._ids else "unknown"
            raise ValueError(f"step: agent {unknown[0]!r} is {what}; live agents: {self.agents}")
        missing = [name for name in self.agents if name not in actions]
        if missing:
            raise ValueError(f"step: no action for {missing} (every live agent acts); "
                             f"live agents: {self.agents}")
        obs, rewards, terminateds, truncateds, infos = self.env.step(
            {self._ids[name]: check_action(action, name, self.env.radio)
             for name, action in actions.items()})
        acted = [self._ids[name] for name in self.agents]
        self.agents = [_name(a) for a in self.env.agents]
        return (self._named(obs), self._named(rewards), self._named(terminateds),
                {_name(a): False for a in acted}, self._named(infos))

    @staticmethod
    def _named(per_agent: dict) -> dict:
        return {_name(a): value for a, value in per_agent.items() if a != "__all__"}

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() without a render_mode: pass render_mode='rgb_array'")
            return None
        return self.env.draw()

    def close(self):
        pass


def parallel_env(render_mode: str | None = None, **config) -> PommeParallelEnv:
    """The PettingZoo env; keyword arguments are its config (seed, max_steps, reward,
    observation, game)."""
    return PommeParallelEnv(config, render_mode)
