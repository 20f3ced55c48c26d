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
  dies in the same blast), so a kill is paid when it happens and a suicide never;
* "raw_kills_clock" (ours): "raw_kills", plus a clock: every step an agent plays costs
  CLOCK_COST / max_steps, and an agent whose last step is not its team's win also pays the rest
  of the clock to the step limit. A tie or a loss so costs CLOCK_COST more than "raw_kills"
  pays for them, whenever it comes (dying early saves nothing), while a win keeps what was
  left of the clock: a win at step t pays CLOCK_COST * (1 - t / max_steps) more than a win at
  the step limit, so a team that waits for the careful opponents to err earns less than one
  that wins early.
* "raw_kills_room" (ours): "raw_kills", plus a potential-based shaping (Ng et al. 1999) on how
  cornered the enemies stand. An agent's potential is ROOM_WEIGHT for each living enemy, times
  the share of ROOM_CAP cells that enemy could NOT reach alive within ROOM_HORIZON steps if the
  agent's team laid a bomb where each of them stands now (agents/survival.rooms_under_threat;
  ROOM_CAP cells or more: 0, none: 1);
* "raw_kills_trap" (ours): "raw_kills", plus the same kind of shaping on the enemies already
  trapped: TRAP_WEIGHT for each living enemy that has no way to survive ROOM_HORIZON steps if
  nobody lays another bomb, so the step whose bomb closes the last way out is paid then, not
  only at the kill some ten steps later.

In both, each step pays the potential after it minus the potential before, and an agent's last
step counts the potential after as 0. The payments of a game so add up to minus the potential
the agent started with (near nought: the game begins with the enemies far), whatever it did:
the shaping moves credit to the steps that corner or trap an enemy (and back out of those that
let it go) without changing which play is best (up to gamma 0.999's 0.1% a step). A trapped
enemy's death takes its potential back on the step the kill is paid.

Every other step pays nothing (but the clock's share, in "raw_kills_clock"). Written here,
below every env and the curriculum checker, so that each reads the same modes without importing
the other.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .constants import BOMB_LIFE_AT_LAYING, NUM_AGENTS, Result
from .kills import death_cause

REWARD_MODES = ("shaped", "raw", "shaped_credit", "raw_kills", "raw_kills_clock", "raw_kills_room",
                "raw_kills_trap")
KILL_BONUS = 0.5
CLOCK_COST = 0.5  # what the whole clock costs in "raw_kills_clock"
ROOM_WEIGHT = 0.2  # an enemy fully cornered, in "raw_kills_room"'s potential
TRAP_WEIGHT = 0.3  # an enemy trapped, in "raw_kills_trap"'s potential
ROOM_CAP = 8  # cells of room at which an enemy counts as free
ROOM_HORIZON = BOMB_LIFE_AT_LAYING  # steps the scenarios run: a bomb laid now goes off
# The modes paid on the enemies' rooms (agents/survival.rooms_under_threat): their weights for
# (cornered, trapped)
CORNERING_WEIGHTS = {"raw_kills_room": (ROOM_WEIGHT, 0.0), "raw_kills_trap": (0.0, TRAP_WEIGHT)}
_RAW = ("raw", "raw_kills", "raw_kills_clock", *CORNERING_WEIGHTS)  # the engine's outcome
_KILLS = ("raw_kills", "raw_kills_clock", *CORNERING_WEIGHTS)  # paid for credited kills


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
    if mode in _RAW:
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
    if mode not in _KILLS:
        return 0.0
    return KILL_BONUS * sum(1 for e in newly_dead
                            if e % 2 != agent % 2 and _killed_by_enemies(e, killers))


def clock_reward(mode: str, step: int, max_steps: int, last: bool, won: bool) -> float:
    """What an agent pays to the clock on the game's `step` (counted from 1) that it plays: its
    share, and at its `last` step, unless its team `won`, the rest of the clock."""
    if mode != "raw_kills_clock":
        return 0.0
    steps = 1 + (max_steps - step if last and not won else 0)
    return -CLOCK_COST * steps / max_steps


def cornering_potential(mode: str, agent: int, rooms: Sequence[int], trapped: Sequence[bool],
                        alive: Sequence[bool]) -> float:
    """`agent`'s potential under `mode` (one of CORNERING_WEIGHTS): per living enemy, the
    cornered weight scaled by the share of ROOM_CAP cells its room (`rooms`,
    agents/survival.rooms_under_threat) lacks, plus the trapped weight if it is `trapped`."""
    cornered, trap = CORNERING_WEIGHTS[mode]
    return sum(cornered * (1.0 - min(int(rooms[e]), ROOM_CAP) / ROOM_CAP) + trap * bool(trapped[e])
               for e in range(NUM_AGENTS) if e % 2 != agent % 2 and alive[e])


def cornering_reward(mode: str, agent: int, before: tuple, after: tuple, last: bool) -> float:
    """What `agent` is paid on a step for cornering and trapping its enemies: the potential
    after the step (nought at its `last` step) minus the potential before; `before` and
    `after` are each (rooms, trapped, alive) for every seat. Nought in the other modes."""
    if mode not in CORNERING_WEIGHTS:
        return 0.0
    return (0.0 if last else cornering_potential(mode, agent, *after)) - \
        cornering_potential(mode, agent, *before)
