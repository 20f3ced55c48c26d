"""Reward modes: the paper's shaping pays an enemy's suicide, ours pay only credited kills, the
clock charges every game that is not won the whole clock, and the cornering shaping pays a
trapped enemy's step and adds up over a game to minus where it started."""

from __future__ import annotations

import numpy as np
import pytest

from rllib_pommer.agents.survival import rooms_under_threat
from rllib_pommer.envs.team import MultiAgentTeam
from rllib_pommer.game.constants import Action, Item
from rllib_pommer.game.rewards import (
    CLOCK_COST,
    KILL_BONUS,
    ROOM_CAP,
    ROOM_HORIZON,
    ROOM_WEIGHT,
    TRAP_WEIGHT,
    clock_reward,
    cornering_potential,
    cornering_reward,
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


def _load_open_board(env, cells: dict, bombs: list, rigid: tuple = ()) -> None:
    """An open board (passages, `rigid` walls) with the seats on `cells` and `bombs` laid."""
    state = env.game.dump()
    board = [[int(Item.PASSAGE)] * 11 for _ in range(11)]
    for row, col in rigid:
        board[row][col] = int(Item.RIGID)
    for seat, entry in enumerate(state["agents"]):
        entry["position"] = list(cells[seat])
        board[cells[seat][0]][cells[seat][1]] = int(Item.AGENT0) + seat
    for bomb in bombs:
        board[bomb["position"][0]][bomb["position"][1]] = int(Item.BOMB)
    state.update(board=board, items=[], flames=[], bombs=bombs)
    env.game.load(state)


def test_the_env_pays_a_kill_on_the_step_it_happens():
    env = MultiAgentTeam({"reward": "raw_kills", "seed": 0})
    env.reset()
    _load_open_board(env, {0: (0, 0), 1: (5, 6), 2: (10, 10), 3: (0, 10)}, [
        {"position": [5, 5], "bomber_id": 0, "life": 1, "blast_strength": 3,
         "moving_direction": None}])
    _, rewards, terminateds, _, infos = env.step(dict.fromkeys(range(4), int(Action.STOP)))
    assert terminateds[1] and not terminateds["__all__"]
    assert rewards == {0: KILL_BONUS, 1: -1.0, 2: KILL_BONUS, 3: 0.0}


def _random_game(mode: str, max_steps: int, seed: int) -> tuple[dict, dict, list, tuple]:
    """A game of uniformly random moves paid `mode`: each agent's total, its (last step,
    winners), every step's rewards of the agents that went on, and (rooms, alive) at reset."""
    env = MultiAgentTeam({"reward": mode, "seed": seed, "max_steps": max_steps})
    env.reset()
    start = env._cornering()
    paid, last, done, going_on = dict.fromkeys(range(4), 0.0), {}, False, []
    rng = np.random.default_rng(seed)
    while not done:
        _, rewards, terminateds, _, infos = env.step(
            {agent: int(rng.integers(6)) for agent in env.agents})
        for agent, reward in rewards.items():
            paid[agent] += reward
            if terminateds[agent]:
                last[agent] = (len(going_on) + 1, infos[agent].get("winners"))
        going_on.append({a: r for a, r in rewards.items() if not terminateds[a]})
        done = terminateds["__all__"]
    return paid, last, going_on, start


def test_the_clock_makes_every_non_win_cost_the_whole_clock_and_a_win_keep_the_rest():
    """Played out in the env: summed over an agent's steps, a tie and an early death both cost
    CLOCK_COST beyond "raw_kills"; a win at step t keeps CLOCK_COST * (1 - t / max_steps)."""
    seen = set()
    for seed in range(12):
        plain, _, steps, _ = _random_game("raw_kills", 60, seed)
        clock, last, same_steps, _ = _random_game("raw_kills_clock", 60, seed)
        assert len(steps) == len(same_steps)  # the reward changes nothing in the game
        for agent in range(4):
            step, winners = last[agent]
            won = bool(winners) and agent in winners
            extra = -CLOCK_COST * (step / 60 if won else 1.0)
            assert clock[agent] - plain[agent] == pytest.approx(extra), (seed, agent, last)
            seen.add("win" if won else "tie" if step == 60 else "death")
    assert seen == {"win", "tie", "death"}, seen
    assert clock_reward("raw_kills", 5, 60, True, False) == 0.0


def test_an_enemy_in_a_dead_end_beside_us_has_no_room_and_a_free_one_the_cap():
    """Agent 1 stands in a dead end whose one way out agent 0 blocks: a bomb of agent 0 laid now
    would trap it (room 0), but it is not trapped yet. Everyone else stands in the open (room
    ROOM_CAP); a dead seat 0."""
    env = MultiAgentTeam({"reward": "raw_kills_room", "seed": 0})
    env.reset()
    _load_open_board(env, {0: (1, 5), 1: (0, 5), 2: (10, 0), 3: (9, 9)}, [],
                     rigid=((0, 4), (0, 6)))
    rooms, trapped, alive = env._cornering()
    assert rooms.tolist() == [ROOM_CAP, 0, ROOM_CAP, ROOM_CAP] and not trapped.any()
    now = (rooms, trapped, alive)
    assert cornering_potential("raw_kills_room", 0, *now) == pytest.approx(ROOM_WEIGHT)
    assert cornering_potential("raw_kills_room", 1, *now) == 0.0  # its enemies are free
    assert cornering_potential("raw_kills_trap", 0, *now) == 0.0  # not trapped yet
    state = env.game.batch.state
    agents = state.agents[0].copy()
    agents[1, 2] = 0  # seat 1 dead
    assert rooms_under_threat(state.board[0], agents, state.bombs[0], state.flames[0],
                              state.items[0], state.meta[0], state.radio[0], ROOM_HORIZON,
                              ROOM_CAP)[1] == 0
    assert cornering_potential("raw_kills_room", 0, rooms, trapped,
                               [True, False, True, True]) == 0.0


def test_the_bomb_that_closes_the_way_out_is_paid_on_its_step():
    """Agent 0 lays its bomb at the mouth of agent 1's dead end and steps aside: under
    "raw_kills_trap" the laying step pays TRAP_WEIGHT to agents 0 and 2 and takes it from
    nobody else; under "raw_kills" it pays nothing."""
    paid = {}
    for mode in ("raw_kills", "raw_kills_trap"):
        env = MultiAgentTeam({"reward": mode, "seed": 0})
        env.reset()
        _load_open_board(env, {0: (1, 5), 1: (0, 5), 2: (10, 0), 3: (9, 9)}, [],
                         rigid=((0, 4), (0, 6)))
        _, paid[mode], _, _, _ = env.step({0: int(Action.BOMB), 1: int(Action.STOP),
                                           2: int(Action.STOP), 3: int(Action.STOP)})
    assert paid["raw_kills"] == dict.fromkeys(range(4), 0.0)
    assert paid["raw_kills_trap"] == pytest.approx({0: TRAP_WEIGHT, 1: 0.0, 2: TRAP_WEIGHT,
                                                    3: 0.0})


@pytest.mark.parametrize("mode", ["raw_kills_room", "raw_kills_trap"])
def test_the_cornering_shaping_adds_up_to_minus_the_first_potential_over_a_game(mode):
    """Played out in the env: each agent's total under `mode` minus its total under
    "raw_kills" is minus its potential at the start, whatever was played, and the game is the
    same; the steps in between are paid (the shaping is not nought along the way)."""
    moved = False
    for seed in range(8):
        plain, _, steps, _ = _random_game("raw_kills", 120, seed)
        shaped, _, same_steps, start = _random_game(mode, 120, seed)
        assert len(steps) == len(same_steps)
        for agent in range(4):
            assert shaped[agent] - plain[agent] == \
                pytest.approx(-cornering_potential(mode, agent, *start)), (seed, agent)
        moved = moved or steps != same_steps
    assert moved  # paid along the way, not only at the end
    before = ([0, 0, ROOM_CAP, ROOM_CAP], [True] * 4, [True] * 4)
    assert cornering_reward("raw_kills", 0, before, before, False) == 0.0
