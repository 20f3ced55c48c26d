"""A PettingZoo `ParallelEnv` face over `PommeEnv`, for tools that speak PettingZoo.

Same game, observations, rewards and seeding; agents are named "player_0".."player_3" (PettingZoo
convention), and an agent that dies leaves `agents` after its last step, as in PettingZoo's
parallel API.
"""

from __future__ import annotations

from copy import deepcopy

from pettingzoo import ParallelEnv

from .env import ACTION_SPACE, OBSERVATION_SPACE, PommeEnv


def _name(agent: int) -> str:
    return f"player_{agent}"


class PommeParallelEnv(ParallelEnv):
    """The four-agent Team game as a PettingZoo `ParallelEnv` (agents "agent_0".."agent_3")."""
    metadata = {"name": "pommerman_team_v0", "render_modes": []}

    def __init__(self, config: dict | None = None):
        self.env = PommeEnv(config)
        self.possible_agents = [_name(a) for a in self.env.possible_agents]
        self._ids = {_name(a): a for a in self.env.possible_agents}
        self.agents = []
        # Own space objects per agent, so seeding one agent's space never moves another's.
        self._observation_spaces = {n: deepcopy(OBSERVATION_SPACE) for n in self.possible_agents}
        self._action_spaces = {n: deepcopy(ACTION_SPACE) for n in self.possible_agents}

    def observation_space(self, agent):
        return self._observation_spaces[agent]

    def action_space(self, agent):
        return self._action_spaces[agent]

    def reset(self, seed=None, options=None):
        obs, infos = self.env.reset(seed=seed, options=options)
        self.agents = [_name(a) for a in self.env.agents]
        return self._named(obs), self._named(infos)

    def step(self, actions):
        obs, rewards, terminateds, truncateds, infos = self.env.step(
            {self._ids[name]: action for name, action in actions.items()})
        acted = [self._ids[name] for name in self.agents]
        self.agents = [_name(a) for a in self.env.agents]
        return (self._named(obs), self._named(rewards), self._named(terminateds),
                {_name(a): False for a in acted}, self._named(infos))

    @staticmethod
    def _named(per_agent: dict) -> dict:
        return {_name(a): value for a, value in per_agent.items() if a != "__all__"}

    def close(self):
        pass
