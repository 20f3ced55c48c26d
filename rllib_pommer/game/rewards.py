"""What an agent of a Team game is paid: nothing until its last step, then its mode's reward.

An agent's last step is its death or the game's end. There `mode` decides:

* "shaped" (the paper, Meisheri et al. 2019): +1 if the agent's team won, else +0.5 if exactly one
  enemy is dead, else -1, judged at the agent's last step;
* "raw": the engine's reward (+1 win, -1 loss or tie) for agents present at the end, -1 for an
  agent that died before (it cannot see the outcome any more).

Written here, below every env and the curriculum checker, so that each reads the same modes
without importing the other.
"""

from __future__ import annotations

import numpy as np

from .constants import NUM_AGENTS, Result

REWARD_MODES = ("shaped", "raw")


def check_reward_mode(mode: str) -> str:
    if mode not in REWARD_MODES:
        raise ValueError(f"reward mode {mode!r} is not one of {list(REWARD_MODES)}")
    return mode


def final_reward(mode: str, agent: int, done: bool, info: dict, engine_reward: float,
                 alive: np.ndarray) -> float:
    """`agent`'s reward at its last step: the game's end (`done`, with the engine's `info` and
    `engine_reward`) or its death; `alive` is every seat's, after the step."""
    if mode == "raw":
        return float(engine_reward) if done else -1.0
    if done and info["result"] == Result.WIN and agent in info["winners"]:
        return 1.0
    enemies_dead = sum(not alive[e] for e in range(NUM_AGENTS) if e % 2 != agent % 2)
    return 0.5 if enemies_dead == 1 else -1.0
