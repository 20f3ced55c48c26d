"""Scripted agents: their rules, their randomness, and valid actions on any observation."""

from __future__ import annotations

import gzip
import json
from itertools import islice

import numpy as np
import pytest

from rllib_pommer.agents.action_filter import ActionFilter, safe_actions
from rllib_pommer.agents.base import Agent
from rllib_pommer.agents.jitter import JitterCorrection
from rllib_pommer.agents.scripted import (
    RULES,
    RandomAgent,
    SimpleAgentNoBomb,
    SmartRandom,
    StaticAgent,
    SuicideTeammate,
)
from rllib_pommer.agents.simple import SimpleAgent, SimpleMemory
from rllib_pommer.game.constants import Action, Item
from rllib_pommer.game.observation import Observation, empty_observations
from rllib_pommer.game.serialize import load_observation

from ..conftest import PUBLIC_GAMES as GAMES

SCRIPTED = [StaticAgent, RandomAgent, SimpleAgentNoBomb, SuicideTeammate, SmartRandom, SimpleAgent]
WRAPPINGS = {
    "plain": lambda agent: agent,
    "jitter": JitterCorrection,
    "action": ActionFilter,
    "jitter_action": lambda agent: ActionFilter(JitterCorrection(agent)),
}
BOARD_CODES = np.array([0, 0, 0, 0, 1, 1, 2, 2, 3, 4, 6, 7, 8])


def random_observation(rng: np.random.Generator) -> Observation:
    """A chaotic but well-typed observation: random walls, items, bombs, flames, agents and fog."""
    agent_id = int(rng.integers(4))
    obs = Observation(*(np.array(f) for f in empty_observations(1).select(0, agent_id)))
    obs.board[:] = rng.choice(BOARD_CODES, size=(11, 11))
    bombs = obs.board == Item.BOMB
    obs.bomb_life[bombs] = rng.integers(1, 10, bombs.sum())
    obs.bomb_blast_strength[bombs] = rng.integers(1, 6, bombs.sum())
    obs.bomb_moving_direction[bombs] = rng.integers(0, 5, bombs.sum()) * (rng.random() < 0.5)
    flames = obs.board == Item.FLAMES
    obs.flame_life[flames] = rng.integers(1, 4, flames.sum())
    cells = rng.choice(121, size=4, replace=False)
    for other, cell in enumerate(cells):
        obs.board[divmod(int(cell), 11)] = Item.AGENT0 + other  # some stand on bombs
    obs.position[:] = divmod(int(cells[agent_id]), 11)
    obs.game_type[...] = rng.choice([1, 2])
    if obs.game_type == 2:
        rows, cols = np.indices((11, 11))
        out_of_view = np.maximum(abs(rows - obs.position[0]), abs(cols - obs.position[1])) > 4
        obs.board[out_of_view] = Item.FOG
        maps = (obs.bomb_life, obs.bomb_blast_strength, obs.bomb_moving_direction, obs.flame_life)
        for plane in maps:
            plane[out_of_view] = 0
    obs.alive[:] = rng.random(4) < 0.8
    obs.ammo[...] = rng.integers(0, 4)
    obs.blast_strength[...] = rng.integers(1, 5)
    obs.can_kick[...] = rng.random() < 0.5
    obs.step_count[...] = rng.integers(0, 800)
    return obs


def recorded_observations(agent_id: int) -> list[Observation]:
    """One agent's observations through the first long four-SimpleAgent Team game."""
    with gzip.open(GAMES, "rt") as f:
        game = json.loads(next(islice(f, 1, None)))
    assert game["agent_mix"] == "SSSS" and game["num_steps"] > 100
    dicts = [game["initial_observations"]] + [s["observations"] for s in game["steps"]]
    return [load_observation(d[agent_id], agent_id) for d in dicts]


@pytest.mark.parametrize("wrapping", WRAPPINGS)
@pytest.mark.parametrize("agent_class", SCRIPTED, ids=lambda cls: cls.__name__)
def test_actions_are_always_valid(agent_class, wrapping):
    agent = WRAPPINGS[wrapping](agent_class())
    assert isinstance(agent, Agent)
    rng = np.random.default_rng(7)
    agent.reset(0, 2, np.random.default_rng(1))
    for _ in range(60):
        action = agent.act(random_observation(rng))
        assert type(action) is int and 0 <= action < 6


def test_static_agent_always_stops():
    agent = StaticAgent()
    agent.reset(1, 2, np.random.default_rng(0))
    rng = np.random.default_rng(3)
    assert {agent.act(random_observation(rng)) for _ in range(20)} == {Action.STOP}


def test_random_agent_is_uniform_and_seeded():
    obs = random_observation(np.random.default_rng(0))

    def play(seed, n):
        agent = RandomAgent()
        agent.reset(0, 2, np.random.default_rng(seed))
        return [agent.act(obs) for _ in range(n)]

    counts = np.bincount(play(5, 3000), minlength=6)
    assert counts.min() > 400  # 500 expected each
    assert play(5, 50) == play(5, 50) != play(6, 50)


def test_suicide_teammate_bombs_on_the_first_step_then_stops():
    agent = SuicideTeammate()
    obs = random_observation(np.random.default_rng(0))
    for _ in range(2):  # and again after a reset
        agent.reset(2, 2, np.random.default_rng(0))
        actions = []
        for step in range(12):
            obs.step_count[...] = step
            actions.append(agent.act(obs))
        assert actions == [Action.BOMB] + [Action.STOP] * 11


def test_smart_random_picks_only_safe_actions():
    rng = np.random.default_rng(11)
    agent = SmartRandom()
    agent.reset(0, 2, np.random.default_rng(2))
    vetoed = 0
    for _ in range(300):
        obs = random_observation(rng)
        safe = safe_actions(obs)
        action = agent.act(obs)
        assert safe[action] or not safe.any()
        vetoed += not safe.all()
    assert vetoed > 30  # the random boards do put the agent in danger


def test_simple_nobomb_is_simple_agent_with_stop_for_bomb():
    observations = recorded_observations(agent_id=0)
    simple, nobomb = SimpleAgent(), SimpleAgentNoBomb()
    simple.reset(0, 2, np.random.default_rng(4))
    nobomb.reset(0, 2, np.random.default_rng(4))
    simple_actions = [simple.act(obs) for obs in observations]
    nobomb_actions = [nobomb.act(obs) for obs in observations]
    assert Action.BOMB in simple_actions
    assert nobomb_actions == [Action.STOP if a == Action.BOMB else a for a in simple_actions]


@pytest.mark.parametrize("kind", list(RULES))
def test_each_agent_class_plays_its_kinds_batched_rule(kind):
    """Four agents of a kind, one per seat of a recorded game, against the catalogue's rule
    on the four rows at once, whose memory rows start as the agents' own: same actions."""
    seats = [recorded_observations(agent_id) for agent_id in range(4)]
    agents = [RULES[kind].agent() for _ in seats]
    for agent_id, agent in enumerate(agents):
        agent.reset(agent_id, 2, np.random.default_rng(agent_id))
    memory = None
    if RULES[kind].remembers:
        rows = zip(*(agent.memory for agent in agents), strict=True)
        memory = SimpleMemory(*(np.concatenate(row) for row in rows))
    played = []
    for step in zip(*seats, strict=True):
        rows = Observation(*(np.stack(fields) for fields in zip(*step, strict=True)))
        batched = RULES[kind].actions(rows, memory).tolist()
        assert batched == [agent.act(obs) for agent, obs in zip(agents, step, strict=True)]
        played += batched
    fixed_sets = {"static": {Action.STOP}, "suicide": {Action.STOP, Action.BOMB}}
    assert set(played) == fixed_sets[kind] if kind in fixed_sets else len(set(played)) > 3
