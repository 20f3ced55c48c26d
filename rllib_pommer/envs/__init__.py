"""Team Pommerman for your own code, without Ray or torch: a PettingZoo env and a Gymnasium env.

    from rllib_pommer.envs import parallel_env        # PettingZoo ParallelEnv, four agents
    env = parallel_env(render_mode="rgb_array")

    import gymnasium, rllib_pommer.envs                # registers rllib_pommer/PommeTeam-v0
    env = gymnasium.make("rllib_pommer/PommeTeam-v0", teammate="simple", opponents="static")

Both play the compiled game with the paper's 19-plane observations and the training's rewards
(`team.MultiAgentTeam`, which RLlib's env `rl/env.py` shares) and draw frames with the replay
renderer; `game="radio"` (or `rllib_pommer/PommeRadio-v0`) plays TeamRadio, where agents also
send their teammate two words a step. Importing this package imports neither Ray nor torch
(tests/test_layering.py); a learned policy named as a teammate or opponent brings torch in when
it is built.
"""

from __future__ import annotations

import gymnasium

from .multi_agent import PommeParallelEnv, parallel_env
from .single_agent import ENV_ID, RADIO_ENV_ID, PommeTeamEnv
from .team import MultiAgentTeam

__all__ = ["ENV_ID", "RADIO_ENV_ID", "MultiAgentTeam", "PommeParallelEnv", "PommeTeamEnv",
           "parallel_env"]

gymnasium.register(id=ENV_ID, entry_point="rllib_pommer.envs.single_agent:PommeTeamEnv")
gymnasium.register(id=RADIO_ENV_ID, entry_point="rllib_pommer.envs.single_agent:PommeTeamEnv",
                   kwargs={"game": "radio"})
