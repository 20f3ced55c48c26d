"""The Action Filter (paper Algorithm 2) and the Jitter Correction (Algorithm 1) on built cases."""

from __future__ import annotations

import gzip
import json

import numpy as np
import pytest

from rllib_pommer.agents.action_filter import ActionFilter, deadly_cells, safe_actions
from rllib_pommer.agents.jitter import JitterCorrection, expert_steps_for
from rllib_pommer.agents.simple import SimpleAgent
from rllib_pommer.game.constants import ACTION_DC, ACTION_DR, Action, Item
from rllib_pommer.game.observation import Observation, empty_observations
from rllib_pommer.game.serialize import load_observation

from ..conftest import PUBLIC_GAMES as GAMES

STOP, UP, DOWN, LEFT, RIGHT, BOMB = (int(a) for a in Action)
ME = (5, 5)


def make_obs(position=ME, agent_id=0) -> Observation:
    """An empty open board with only this agent on it, every field a writable array."""
    obs = Observation(*(np.array(f) for f in empty_observations(1).select(0, agent_id)))
    obs.position[:] = position
    obs.board[position] = Item.AGENT0 + agent_id
    obs.alive[:] = True
    obs.game_type[...] = 2
    obs.ammo[...] = 1
    obs.blast_strength[...] = 2
    return obs


def put_bomb(obs, cell, life, strength=2, direction=0):
    if obs.board[cell] < Item.AGENT0:
        obs.board[cell] = Item.BOMB
    obs.bomb_life[cell] = life
    obs.bomb_blast_strength[cell] = strength
    obs.bomb_moving_direction[cell] = direction


def put_flame(obs, cell, flame_life):
    obs.board[cell] = Item.FLAMES
    obs.flame_life[cell] = flame_life


def safe_set(obs):
    return {a for a in range(6) if safe_actions(obs)[a]}


# --- Action filter: the flame prediction --------------------------------------------------------


def test_bomb_with_life_one_makes_its_cross_deadly():
    obs = make_obs()
    put_bomb(obs, (5, 7), life=1)
    expected = np.zeros((11, 11), bool)
    expected[[5, 5, 5, 4, 6], [6, 7, 8, 7, 7]] = True
    assert np.array_equal(deadly_cells(obs), expected)
    assert safe_set(obs) == {STOP, UP, DOWN, LEFT, BOMB}


def test_bomb_with_more_life_is_not_deadly_yet():
    obs = make_obs()
    put_bomb(obs, (5, 6), life=2, strength=4)
    assert not deadly_cells(obs).any()
    assert safe_set(obs) == set(range(6))


@pytest.mark.parametrize("flame_life, safe", [(3, False), (2, False), (1, True)])
def test_flames_persist_unless_flame_life_is_one(flame_life, safe):
    obs = make_obs()
    put_flame(obs, (4, 5), flame_life)
    assert bool(safe_actions(obs)[UP]) is safe
    assert safe_set(obs) - {UP} == {STOP, DOWN, LEFT, RIGHT, BOMB}


def test_chain_explosion_reaches_further():
    obs = make_obs()
    put_bomb(obs, (5, 9), life=1)  # its cross covers (5, 8) ...
    put_bomb(obs, (5, 8), life=6, strength=4)  # ... which sets this one off, reaching (5, 5)
    assert deadly_cells(obs)[ME]
    assert safe_set(obs) == {UP, DOWN, LEFT}
    obs.bomb_life[5, 9] = 2
    assert safe_set(obs) == set(range(6))


def test_bomb_on_a_persisting_flame_goes_off():
    obs = make_obs()
    put_bomb(obs, (3, 5), life=7, direction=DOWN)  # moves onto the flame below it and explodes
    put_flame(obs, (4, 5), 2)
    assert deadly_cells(obs)[ME]


def test_walls_stop_the_blast():
    obs = make_obs()
    put_bomb(obs, (5, 8), life=1, strength=4)
    obs.board[5, 7] = Item.WOOD
    deadly = deadly_cells(obs)
    assert deadly[5, 7] and not deadly[5, 6]
    obs.board[5, 7] = Item.RIGID
    assert not deadly_cells(obs)[5, 7]


def test_bomb_under_an_agent_is_read_from_the_bomb_maps():
    obs = make_obs()
    put_bomb(obs, ME, life=1, strength=2)  # the board still shows the agent
    assert obs.board[ME] == Item.AGENT0
    assert not safe_actions(obs).any()


def test_moving_bomb_may_explode_on_its_next_cell():
    obs = make_obs()
    put_bomb(obs, (5, 7), life=1, direction=LEFT)  # may reach (5, 6), whose cross holds (5, 5)
    assert deadly_cells(obs)[ME] and deadly_cells(obs)[5, 8]
    obs.bomb_moving_direction[5, 7] = 0
    assert not deadly_cells(obs)[ME]


# --- Action filter: the cell an action ends on -------------------------------------------------


def test_blocked_move_is_judged_on_the_current_cell():
    obs = make_obs()
    put_bomb(obs, (5, 7), life=1, strength=3)  # cross reaches (5, 5)
    obs.board[4, 5] = Item.WOOD
    obs.board[6, 5] = Item.RIGID
    assert safe_set(obs) == {LEFT}


def test_move_onto_an_occupied_cell_needs_both_cells_safe():
    obs = make_obs()
    put_bomb(obs, (5, 7), life=1, strength=3)  # current cell deadly
    obs.board[5, 4] = Item.AGENT1  # the move left may bounce
    obs.board[4, 5] = Item.RIGID
    obs.board[6, 5] = Item.RIGID
    assert safe_set(obs) == set()
    obs.bomb_life[5, 7] = 3
    assert safe_set(obs) == set(range(6))


def test_matches_the_reference_flames_in_recorded_games():
    """Biased-random power-start games (many chains): FFA exactly, Team wherever the agent sees.

    Left out: steps where a bomb moves or may be kicked (an agent walks into a bomb), and steps
    where an agent lays a bomb inside the predicted blast (it goes off at once): these depend on
    other agents' actions, which the observer cannot know.
    """
    power_starts = ('"agent_mix":"BBBB+"', '"agent_mix":"bbbb+"')
    with gzip.open(GAMES, "rt") as f:
        games = [json.loads(line) for line in f if any(m in line[:120] for m in power_starts)]
    assert len(games) == 45
    checked = chains = 0
    for game in games:
        full_view = "FFA" in game["env_id"]
        # The state and the observations each step starts from.
        states = [game["initial_state"]] + [s["state"] for s in game["steps"][:-1]]
        observations = [game["initial_observations"]]
        observations += [s["observations"] for s in game["steps"][:-1]]
        for step, state, before in zip(game["steps"], states, observations, strict=True):
            bombs = {tuple(b["position"]) for b in state["bombs"]}
            targets = [
                (o["position"][0] + ACTION_DR[a], o["position"][1] + ACTION_DC[a])
                for o, a in zip(before, step["actions"], strict=True)
            ]
            if any(b["moving_direction"] for b in state["bombs"]) or bombs & set(targets):
                continue
            layers = [cell for cell, a in zip(targets, step["actions"], strict=True) if a == BOMB]
            flames_after = np.array(step["state"]["board"]) == Item.FLAMES
            for agent_id, obs_dict in enumerate(before):
                obs = load_observation(obs_dict, agent_id)
                deadly = deadly_cells(obs)
                if any(deadly[cell] for cell in layers):
                    continue
                if full_view:
                    assert np.array_equal(deadly, flames_after)
                else:
                    assert not (deadly & ~flames_after & (obs.board != Item.FOG)).any()
                checked += 1
                chains += "chain_explosion" in step.get("events", ())
    assert checked > 1500 and chains > 80


# --- Action filter: the wrapper -------------------------------------------------------------------


class Constant:
    def __init__(self, action):
        self.action = action
        self.calls = 0

    def reset(self, agent_id, game_type, rng):
        pass

    def act(self, obs):
        self.calls += 1
        return self.action


def test_filter_keeps_a_safe_action():
    obs = make_obs()
    put_bomb(obs, (5, 7), life=1)
    agent = ActionFilter(Constant(BOMB))
    agent.reset(0, 2, np.random.default_rng(0))
    assert agent.act(obs) == BOMB


def test_filter_replaces_a_deadly_action_uniformly_by_safe_moves():
    obs = make_obs()
    put_bomb(obs, (5, 7), life=1)
    agent = ActionFilter(Constant(RIGHT))
    counts = np.zeros(6, int)
    for seed in range(400):
        agent.reset(0, 2, np.random.default_rng(seed))
        counts[agent.act(obs)] += 1
    assert counts[RIGHT] == counts[BOMB] == 0
    assert counts[[STOP, UP, DOWN, LEFT]].min() > 60  # 100 expected each


def test_filter_keeps_the_action_when_nothing_is_safe():
    obs = make_obs()
    put_bomb(obs, ME, life=1)
    agent = ActionFilter(Constant(UP))
    agent.reset(0, 2, np.random.default_rng(0))
    assert agent.act(obs) == UP


# --- Jitter correction --------------------------------------------------------------------------


def walk(start, steps, direction=(0, 1)):
    return [(start[0] + k * direction[0], start[1] + k * direction[1]) for k in range(steps)]


def test_stationary_for_fifteen_steps_hands_three_steps():
    assert expert_steps_for([(3, 3)] * 14) == 0
    assert expert_steps_for([(3, 3)] * 15) == 3
    assert expert_steps_for([(3, 4)] + [(3, 3)] * 14) == 0


@pytest.mark.parametrize("axis_step", [(0, 1), (1, 0)])
def test_alternating_between_two_cells_hands_two_steps(axis_step):
    a, b = (4, 4), (4 + axis_step[0], 4 + axis_step[1])
    assert expert_steps_for([a, b] * 5 + [a]) == 2  # 11 positions
    assert expert_steps_for([a, b] * 5) == 0  # 10 are too few
    assert expert_steps_for([a, a] + [b, a] * 5) == 2  # only the last 11 count
    assert expert_steps_for([a, a, b, a, b, a, b, a, b, a, b]) == 0


@pytest.mark.parametrize("axis_step", [(0, 1), (1, 0)])
def test_confined_to_two_cells_for_35_steps_hands_two_steps(axis_step):
    a, b = (6, 2), (6 + axis_step[0], 2 + axis_step[1])
    dawdle = ([a] * 3 + [b] * 4) * 5  # 35 positions, never alternating step by step
    assert expert_steps_for(dawdle) == 2
    assert expert_steps_for(dawdle[1:]) == 0
    assert expert_steps_for([(0, 0)] + dawdle[1:]) == 0


def test_walks_and_wider_loops_are_left_alone():
    assert expert_steps_for(walk((0, 0), 11)) == 0
    assert expert_steps_for(walk((0, 3), 2)) == 0  # a literal reading of Algorithm 1 fires here
    square = [(1, 1), (1, 2), (2, 2), (2, 1)] * 10
    assert expert_steps_for(square) == 0


def run(agent, positions):
    actions = []
    for cell in positions:
        obs = make_obs(cell)
        actions.append(agent.act(obs))
    return actions


def test_jitter_wrapper_switches_control_for_n_steps():
    inner, expert = Constant(RIGHT), Constant(BOMB)
    agent = JitterCorrection(inner, expert)
    agent.reset(0, 2, np.random.default_rng(0))
    positions = [(5, 5)] * 15 + walk((5, 6), 5)
    assert run(agent, positions) == [RIGHT] * 14 + [BOMB] * 3 + [RIGHT] * 3
    assert inner.calls == len(positions) and expert.calls == 3


def test_jitter_wrapper_forgets_its_history_on_reset():
    agent = JitterCorrection(Constant(RIGHT), Constant(BOMB))
    agent.reset(0, 2, np.random.default_rng(0))
    run(agent, [(5, 5)] * 10)
    agent.reset(0, 2, np.random.default_rng(0))
    assert run(agent, [(5, 5)] * 10) == [RIGHT] * 10


def test_jitter_expert_defaults_to_simple_agent():
    agent = JitterCorrection(Constant(STOP))
    assert isinstance(agent.expert, SimpleAgent)
    agent.reset(0, 2, np.random.default_rng(0))
    actions = run(agent, [ME] * 18)
    assert actions[:14] == [STOP] * 14
    assert all(0 <= a < 6 for a in actions)
