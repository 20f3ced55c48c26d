"""Reward modes: the paper's shaping pays an enemy's suicide, ours pay only credited kills, and
the clock charges every game that is not won the whole clock."""

from __future__ import annotations

import numpy as np
import pytest

from rllib_pommer.envs.team import MultiAgentTeam
from rllib_pommer.game.constants import Action, Item
from rllib_pommer.game.rewards import (
    CLOCK_COST,
    KILL_BONUS,
    clock_reward,
    final_reward,
    kill_reward,
)

NO_INFO = {"result": 0}
ALIVE_BUT_1 = np.array([True, False, True, True])


def test_shaped_pays_a_suicide_and_shaped_credit_does_not():
    suicide, killed = [0, 0b0010, 0, 0], [0, 0b0001, 0, 0]  # agent 1 by itself / by agent 0
    for killers, credit in ((suicide, -1.0), (killed, 0.5)):
        assert final_reward("shaped", 0, False, NO_INFO, 0, ALIVE_BUT_1, killers) == 0.5
        assert final_reward("shaped_credit", 0, False, NO_INFO, 0, ALIVE_BUT_1, killers) == credit


def test_raw_kills_pays_each_credited_kill_to_the_killing_team_only():
    killers = [0, 0b0001, 0, 0b1000]  # agent 1 killed by agent 0; agent 3 by itself
    assert kill_reward("raw_kills", 0, [1, 3], killers) == KILL_BONUS
    assert kill_reward("raw_kills", 2, [1, 3], killers) == KILL_BONUS
    assert kill_reward("raw_kills", 3, [1, 3], killers) == 0.0
    assert kill_reward("raw", 0, [1, 3], killers) == 0.0
    assert final_reward("raw_kills", 0, True, {"result": 1}, 1, ALIVE_BUT_1, killers) == 1.0


def test_the_env_pays_a_kill_on_the_step_it_happens():
    env = MultiAgentTeam({"reward": "raw_kills", "seed": 0})
    env.reset()
    state = env.game.dump()
    board = [[int(Item.PASSAGE)] * 11 for _ in range(11)]
    cells = {0: (0, 0), 1: (5, 6), 2: (10, 10), 3: (0, 10)}
    for seat, entry in enumerate(state["agents"]):
        entry["position"] = list(cells[seat])
        board[cells[seat][0]][cells[seat][1]] = int(Item.AGENT0) + seat
    board[5][5] = int(Item.BOMB)
    state.update(board=board, items=[], flames=[], bombs=[
        {"position": [5, 5], "bomber_id": 0, "life": 1, "blast_strength": 3,
         "moving_direction": None}])
    env.game.load(state)
    _, rewards, terminateds, _, infos = env.step(dict.fromkeys(range(4), int(Action.STOP)))
    assert terminateds[1] and not terminateds["__all__"]
    assert rewards == {0: KILL_BONUS, 1: -1.0, 2: KILL_BONUS, 3: 0.0}


def test_the_clock_makes_every_non_win_cost_the_whole_clock_and_a_win_keep_the_rest():
    """Played out in the env: summed over an agent's steps, a tie and an early death both cost
    CLOCK_COST beyond "raw_kills"; a win at step t keeps CLOCK_COST * (1 - t / max_steps)."""
    def totals(mode: str, max_steps: int, seed: int) -> tuple[dict, dict, int]:
        env = MultiAgentTeam({"reward": mode, "seed": seed, "max_steps": max_steps})
        env.reset()
        paid, last, done, steps = dict.fromkeys(range(4), 0.0), {}, False, 0
        rng = np.random.default_rng(seed)
        while not done:
            _, rewards, terminateds, _, infos = env.step(
                {agent: int(rng.integers(6)) for agent in env.agents})
            steps += 1
            for agent, reward in rewards.items():
                paid[agent] += reward
                if terminateds[agent]:
                    last[agent] = (steps, infos[agent].get("winners"))
            done = terminateds["__all__"]
        return paid, last, steps

    seen = set()
    for seed in range(12):
        plain, _, steps = totals("raw_kills", 60, seed)
        clock, last, same_steps = totals("raw_kills_clock", 60, seed)
        assert steps == same_steps  # the reward changes nothing in the game
        for agent in range(4):
            step, winners = last[agent]
            won = bool(winners) and agent in winners
            extra = -CLOCK_COST * (step / 60 if won else 1.0)
            assert clock[agent] - plain[agent] == pytest.approx(extra), (seed, agent, last)
            seen.add("win" if won else "tie" if step == 60 else "death")
    assert seen == {"win", "tie", "death"}, seen
    assert clock_reward("raw_kills", 5, 60, True, False) == 0.0
