"""Team Pommerman as an RLlib `MultiAgentEnv`, registered as "pommerman_team": four agents (ids
0..3), every one exposed.

The game, its observations and rewards are `envs.team.MultiAgentTeam` (no Ray, shared with the
PettingZoo and Gymnasium envs; its docstring says what agents observe, `game/rewards.py` what
they earn); this module adds RLlib's base class and the registration. The training uses the
default "dict" observation, so any policy can sit in any seat;
`env_config={"observation": "planes_last"}` gives the planes alone as a Box, for RLlib's default
model; `env_config={"game": "radio"}` plays TeamRadio ([move, word, word] actions, the teammate's
words in every observation; a curriculum's `game = "radio"` sets it).
"""

from __future__ import annotations

from ray.rllib.env.multi_agent_env import MultiAgentEnv
from ray.tune.registry import register_env

from ..curriculum.names import ENV_NAME
from ..envs.team import MultiAgentTeam


class PommeEnv(MultiAgentTeam, MultiAgentEnv):
    """The Team game for RLlib: `MultiAgentTeam` (whose docstring lists the env_config keys)
    as a `MultiAgentEnv`."""


register_env(ENV_NAME, PommeEnv)
