"""SimpleAgent rules on hand-built boards, robustness on random boards, and reproducibility."""

from __future__ import annotations

import numpy as np
import pytest

from rllib_pommer.agents.simple import SimpleAgent, SimpleMemory, new_memory, simple_actions
from rllib_pommer.game.constants import BOARD_SIZE, Action, GameType, Item
from rllib_pommer.game.observation import Observation

STOP, UP, DOWN, LEFT, RIGHT, BOMB = (int(a) for a in Action)
ME = (5, 5)


def make_obs(
    fill: int = Item.PASSAGE,
    position=ME,
    agent_id: int = 0,
    game_type: int = GameType.TEAM,
    ammo: int = 1,
    blast_strength: int = 2,
) -> Observation:
    """A board filled with `fill` holding only this agent; callers place walls, bombs, others."""
    board = np.full((BOARD_SIZE, BOARD_SIZE), fill, np.uint8)
    board[position] = Item.AGENT0 + agent_id
    zeros = np.zeros((BOARD_SIZE, BOARD_SIZE), np.uint8)
    return Observation(
        board=board,
        bomb_blast_strength=zeros.copy(),
        bomb_life=zeros.copy(),
        bomb_moving_direction=zeros.copy(),
        flame_life=zeros.copy(),
        position=np.array(position, np.int32),
        ammo=np.int32(ammo),
        blast_strength=np.int32(blast_strength),
        can_kick=np.bool_(False),
        alive=np.ones(4, np.bool_),
        agent_id=np.int32(agent_id),
        game_type=np.int32(game_type),
        step_count=np.int32(0),
    )


def put_bomb(obs: Observation, cell, strength: int = 2) -> None:
    if obs.board[cell] < Item.AGENT0:
        obs.board[cell] = Item.BOMB
    obs.bomb_blast_strength[cell] = strength
    obs.bomb_life[cell] = 9


def decide(obs: Observation, seed: int = 0) -> int:
    agent = SimpleAgent()
    agent.reset(int(obs.agent_id), int(obs.game_type), np.random.default_rng(seed))
    return agent.act(obs)


def test_r1_on_own_bomb_takes_the_first_direction_that_is_not_a_dead_end():
    obs = make_obs(fill=Item.RIGID)
    put_bomb(obs, ME)
    # Right (tried first) is a straight dead end within range; Left turns a corner: escapes.
    for cell in [(5, 6), (5, 7), (5, 4), (6, 4), (6, 3)]:
        obs.board[cell] = Item.PASSAGE
    assert decide(obs) == LEFT


def test_r1_on_own_bomb_with_no_exit_stops():
    obs = make_obs(fill=Item.RIGID)
    put_bomb(obs, ME)
    assert decide(obs) == STOP


def test_r1_moves_off_the_line_of_a_bomb_in_reach():
    obs = make_obs()
    put_bomb(obs, (5, 3))
    obs.board[4, 5] = obs.board[6, 5] = Item.RIGID
    assert decide(obs) == RIGHT  # Left is toward the bomb, Up and Down are walls


def test_r2_bombs_an_adjacent_enemy():
    obs = make_obs()
    obs.board[5, 6] = Item.AGENT1
    assert decide(obs) == BOMB


def test_r2_teammate_is_no_target_in_team_but_is_in_ffa():
    team = make_obs(game_type=GameType.TEAM)
    team.board[5, 6] = Item.AGENT2
    assert decide(team) != BOMB
    ffa = make_obs(game_type=GameType.FFA)
    ffa.board[5, 6] = Item.AGENT2
    assert decide(ffa) == BOMB


def test_r3_steps_toward_an_enemy_three_cells_away():
    obs = make_obs(ammo=0)
    obs.board[5, 8] = Item.AGENT3
    assert decide(obs) == RIGHT


def test_r4_steps_toward_a_power_up_two_cells_away():
    obs = make_obs()
    obs.board[7, 5] = Item.KICK
    assert decide(obs) == DOWN


@pytest.mark.parametrize(("ammo", "expected"), [(0, STOP), (1, BOMB)])
def test_r5_next_to_wood_waits_without_ammo_and_bombs_with_it(ammo, expected):
    obs = make_obs(ammo=ammo)
    obs.board[4, 5] = Item.WOOD
    assert decide(obs) == expected


def test_r6_approaches_wood_two_cells_away():
    obs = make_obs()
    obs.board[5, 3] = Item.WOOD
    assert decide(obs) == LEFT


def test_wander_never_picks_a_wall_and_uses_every_open_direction():
    obs = make_obs(fill=Item.RIGID)
    obs.board[4, 5] = obs.board[5, 6] = Item.PASSAGE
    chosen = {decide(obs, seed) for seed in range(40)}
    assert chosen == {UP, RIGHT}  # Stop is dropped when a move exists


def random_observations(rng: np.random.Generator, m: int) -> Observation:
    """`m` observations with random boards of valid codes, bombs, fog and own stats."""
    codes = np.array([0, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 10, 11, 12, 13], np.uint8)
    board = rng.choice(codes, size=(m, BOARD_SIZE, BOARD_SIZE))
    bomb_blast_strength = np.where(
        (board == Item.BOMB) | (rng.random((m, BOARD_SIZE, BOARD_SIZE)) < 0.05),
        rng.integers(1, 11, (m, BOARD_SIZE, BOARD_SIZE)),
        0,
    ).astype(np.uint8)
    position = rng.integers(0, BOARD_SIZE, (m, 2)).astype(np.int32)
    agent_id = rng.integers(0, 4, m).astype(np.int32)
    board[np.arange(m), position[:, 0], position[:, 1]] = Item.AGENT0 + agent_id
    zeros = np.zeros((m, BOARD_SIZE, BOARD_SIZE), np.uint8)
    return Observation(
        board=board,
        bomb_blast_strength=bomb_blast_strength,
        bomb_life=zeros,
        bomb_moving_direction=zeros,
        flame_life=zeros,
        position=position,
        ammo=rng.integers(0, 4, m).astype(np.int32),
        blast_strength=rng.integers(1, 11, m).astype(np.int32),
        can_kick=np.zeros(m, np.bool_),
        alive=np.ones((m, 4), np.bool_),
        agent_id=agent_id,
        game_type=rng.choice(np.array([GameType.FFA, GameType.TEAM], np.int32), m),
        step_count=np.zeros(m, np.int32),
    )


def test_random_observations_always_give_a_valid_action():
    rng = np.random.default_rng(7)
    obs = random_observations(rng, 4000)
    memory = new_memory(4000, rng)
    for _ in range(3):  # later rounds run with non-empty memories
        actions = simple_actions(obs, memory)
        assert actions.shape == (4000,)
        assert actions.min() >= 0 and actions.max() <= 5
    assert len(np.unique(actions)) == 6


def test_batched_kernel_and_agent_wrapper_decide_alike():
    """Row m of the batch, given agent m's memory, decides as agent m does."""
    obs = random_observations(np.random.default_rng(3), 300)
    agents = []
    for m in range(300):
        agent = SimpleAgent()
        agent.reset(int(obs.agent_id[m]), int(obs.game_type[m]), np.random.default_rng(m))
        agents.append(agent)
    memory = SimpleMemory(
        *(np.concatenate(rows) for rows in zip(*(a.memory for a in agents), strict=True))
    )
    for _ in range(3):
        batched = simple_actions(obs, memory)
        single = [agent.act(obs.select(m)) for m, agent in enumerate(agents)]
        np.testing.assert_array_equal(batched, single)


def test_same_seed_gives_the_same_action_sequence():
    obs = random_observations(np.random.default_rng(11), 200)

    def sequence(seed: int) -> list[int]:
        agent = SimpleAgent()
        agent.reset(0, GameType.TEAM, np.random.default_rng(seed))
        return [agent.act(obs.select(m)._replace(agent_id=np.int32(0))) for m in range(200)]

    assert sequence(5) == sequence(5)
    assert sequence(5) != sequence(6)
