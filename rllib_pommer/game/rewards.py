"""What an agent of a Team game is paid, by reward mode.

An agent's last step is its death or the game's end. There `mode` decides its final reward:

* "shaped" (the paper, Meisheri et al. 2019): +1 if the agent's team won, else +0.5 if exactly one
  enemy is dead, else -1, judged at the agent's last step. An enemy's suicide pays as a kill;
* "shaped_credit" (ours): the same, but the +0.5 counts only enemies the agent's team killed
  (`game/kills.py`), so the opponents' suicides are no longer paid;
* "raw": the engine's reward (+1 win, -1 loss or tie) for agents present at the end, -1 for an
  agent that died before (it cannot see the outcome any more);
* "raw_kills" (ours): "raw", plus KILL_BONUS for every enemy the agent's team kills, paid on the
  step the enemy dies to each agent of the team still playing then (the killer included if it
  dies in the same blast), so a kill is paid when it happens and a suicide never.

Every other step pays nothing. Written here, below every env and the curriculum checker, so that
each reads the same modes without importing the other.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .constants import NUM_AGENTS, Result
from .kills import death_cause

REWARD_MODES = ("shaped", "raw", "shaped_credit", "raw_kills")
KILL_BONUS = 0.5


def check_reward_mode(mode: str) -> str:
    if mode not in REWARD_MODES:
        raise ValueError(f"reward mode {mode!r} is not one of {list(REWARD_MODES)}")
    return mode


def _killed_by_enemies(seat: int, killers: Sequence[int]) -> bool:
    """Whether `seat` died by the other team's fire (so, seen from that team, a kill)."""
    return death_cause(seat, killers[seat]) == "enemy"


def final_reward(mode: str, agent: int, done: bool, info: dict, engine_reward: float,
                 alive: np.ndarray, killers: Sequence[int]) -> float:
    """`agent`'s reward at its last step: the game's end (`done`, with the engine's `info` and
    `engine_reward`) or its death; `alive` is every seat's after the step, `killers` their
    kill-credit masks (engine.Games.killers)."""
    if mode in ("raw", "raw_kills"):
        return float(engine_reward) if done else -1.0
    if done and info["result"] == Result.WIN and agent in info["winners"]:
        return 1.0
    enemies_dead = [e for e in range(NUM_AGENTS) if e % 2 != agent % 2 and not alive[e]]
    if mode == "shaped_credit":
        enemies_dead = [e for e in enemies_dead if _killed_by_enemies(e, killers)]
    return 0.5 if len(enemies_dead) == 1 else -1.0


def kill_reward(mode: str, agent: int, newly_dead: Sequence[int], killers: Sequence[int]) -> float:
    """What `agent` is paid on a step for the enemies its team killed in it (`newly_dead`: the
    seats that died in the step)."""
    if mode != "raw_kills":
        return 0.0
    return KILL_BONUS * sum(1 for e in newly_dead
                            if e % 2 != agent % 2 and _killed_by_enemies(e, killers))
