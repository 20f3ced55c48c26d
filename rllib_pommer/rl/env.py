"""Team Pommerman as an RLlib `MultiAgentEnv`: four agents (ids 0..3), every one exposed.

Each agent observes a Dict: "planes", the paper's 19 float planes the networks read, and "raw", its
`Observation` packed into one int16 vector, from which scripted modules and the action filter
rebuild the exact arrays the compiled agents take (`unpack_raw`). One observation form serves every
module, so any policy can sit in any seat (rllib-notes K1).

An agent that dies gets its last observation and its final reward, then leaves; the game ends for
everyone when the engine says so (a team wiped out, or the step limit, a tie). Rewards are zero
until an agent's last step, where `reward_mode` decides them:

* "shaped" (the paper): +1 if the agent's team won, else +0.5 if exactly one enemy is dead, else -1,
  judged at the agent's last step;
* "raw": the engine's reward (+1 win, -1 loss or tie) for agents present at the end, -1 for an
  agent that died before (it cannot see the outcome any more).

The final infos carry `winners` (seats, empty on a tie), so callbacks can log the true outcome
whatever the reward mode. Each reset also draws, from the env's seeded stream, whether the learner's
action filter and jitter correction are on for the episode (`filters` in every info), so the
episode's filters replay with its seed. `set_stage` changes reward mode and filter probabilities.
"""

from __future__ import annotations

from dataclasses import replace

import gymnasium as gym
import numpy as np
from ray.rllib.env.multi_agent_env import MultiAgentEnv
from ray.tune.registry import register_env

from ..features import NUM_PLANES, featurize
from ..game.constants import NUM_ACTIONS, NUM_AGENTS, TEAM, Result
from ..game.engine import Game
from ..game.observation import Observation, empty_observations

ENV_NAME = "pommerman_team"
REWARD_MODES = ("shaped", "raw")

_TEMPLATE = empty_observations(1).select(0, 0)
_FIELD_SHAPES = [np.shape(field) for field in _TEMPLATE]
_FIELD_SIZES = [int(np.prod(shape)) for shape in _FIELD_SHAPES]
RAW_SIZE = sum(_FIELD_SIZES)
_SPLITS = np.cumsum(_FIELD_SIZES)[:-1]

OBSERVATION_SPACE = gym.spaces.Dict({
    "planes": gym.spaces.Box(0.0, 1.0, (NUM_PLANES, 11, 11), np.float32),
    "raw": gym.spaces.Box(0, np.iinfo(np.int16).max, (RAW_SIZE,), np.int16),
})
ACTION_SPACE = gym.spaces.Discrete(NUM_ACTIONS)


def pack_raw(obs: Observation) -> np.ndarray:
    """Observations of leading shape L -> int16 (L..., RAW_SIZE)."""
    lead = obs.board.shape[:-2]
    return np.concatenate(
        [np.asarray(f).reshape(lead + (-1,)).astype(np.int16) for f in obs], axis=-1)


def unpack_raw(raw: np.ndarray) -> Observation:
    """The inverse of `pack_raw`, with the engine's dtypes, for any leading shape."""
    raw = np.asarray(raw)
    lead = raw.shape[:-1]
    parts = np.split(raw, _SPLITS, axis=-1)
    return Observation(*(
        part.reshape(lead + shape).astype(np.asarray(template).dtype)
        for part, shape, template in zip(parts, _FIELD_SHAPES, _TEMPLATE, strict=True)))


def agent_observations(obs: Observation) -> dict[int, dict[str, np.ndarray]]:
    """The four agents' Dict observations from the engine's (4,) observation rows."""
    planes, raw = featurize(obs), pack_raw(obs)
    return {a: {"planes": planes[a], "raw": raw[a]} for a in range(NUM_AGENTS)}


class PommeEnv(MultiAgentEnv):
    """env_config: seed, max_steps (default 800), reward ("shaped"|"raw"), action_filter and
    jitter (per-episode activation probabilities of the learner's filters)."""

    def __init__(self, config: dict | None = None):
        super().__init__()
        config = dict(config or {})
        self.game = Game(replace(TEAM, max_steps=int(config.get("max_steps", TEAM.max_steps))))
        self.possible_agents = list(range(NUM_AGENTS))
        self.agents = []
        self.observation_spaces = dict.fromkeys(self.possible_agents, OBSERVATION_SPACE)
        self.action_spaces = dict.fromkeys(self.possible_agents, ACTION_SPACE)
        self._rng = np.random.default_rng(config.get("seed"))
        self.set_stage(config.get("reward", "shaped"), config.get("action_filter", 0.0),
                       config.get("jitter", 0.0))
        self._filters: dict[str, bool] = {}

    def set_stage(self, reward: str, action_filter: float, jitter: float) -> None:
        if reward not in REWARD_MODES:
            raise ValueError(f"reward mode {reward!r} is not one of {REWARD_MODES}")
        self.reward_mode = reward
        self.filter_probabilities = {"action_filter": float(action_filter),
                                     "jitter": float(jitter)}

    def reset(self, *, seed=None, options=None):
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        obs = self.game.reset(int(self._rng.integers(2**31)))
        self._filters = {name: bool(self._rng.random() < p)
                         for name, p in self.filter_probabilities.items()}
        self.agents = list(self.possible_agents)
        return agent_observations(obs), {a: {"filters": self._filters} for a in self.agents}

    def step(self, action_dict):
        actions = np.zeros(NUM_AGENTS, np.int64)  # dead agents play Stop, as in the engine
        for agent, action in action_dict.items():
            actions[agent] = action
        obs, engine_rewards, done, info = self.game.step(actions)
        alive = self.game.batch.alive[0]
        all_obs = agent_observations(obs)
        acting, self.agents = self.agents, []
        observations, rewards, terminateds, infos = {}, {}, {}, {}
        for agent in acting:
            observations[agent] = all_obs[agent]
            infos[agent] = {"filters": self._filters}
            leaves = done or not alive[agent]
            terminateds[agent] = leaves
            rewards[agent] = self._final_reward(agent, done, info, engine_rewards, alive) \
                if leaves else 0.0
            if done:
                infos[agent]["winners"] = info.get("winners", [])
            if not leaves:
                self.agents.append(agent)
        terminateds["__all__"] = done
        return observations, rewards, terminateds, {"__all__": False}, infos

    def _final_reward(self, agent, done, info, engine_rewards, alive) -> float:
        if self.reward_mode == "raw":
            return float(engine_rewards[agent]) if done else -1.0
        if done and info["result"] == Result.WIN and agent in info["winners"]:
            return 1.0
        enemies_dead = sum(not alive[e] for e in range(NUM_AGENTS) if e % 2 != agent % 2)
        return 0.5 if enemies_dead == 1 else -1.0


register_env(ENV_NAME, PommeEnv)
