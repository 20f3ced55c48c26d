"""The search agent: it sees only its observation, replays exactly by seed, beats SimpleAgent, and
refuses a bad effort naming the file, the key and the value; its tree does not walk onto other
agents, discounts a move another agent could make too, and sees an enemy's trap."""

from __future__ import annotations

import numpy as np
import pytest

from rllib_pommer.agents.belief import empty_belief, rebuild, remember
from rllib_pommer.agents.registry import make_agent, resolve_policy
from rllib_pommer.agents.search import (
    MAX_THREATS,
    Effort,
    SearchAgent,
    _record_threats,
    root_values,
)
from rllib_pommer.agents.survival import escape_cells
from rllib_pommer.arena.match import MatchSpec, play_match
from rllib_pommer.arena.records import summarise
from rllib_pommer.game.constants import BOARD_SIZE, TEAM_PRESET, Action, Item
from rllib_pommer.game.engine import Games
from rllib_pommer.game.state import (
    A_ALIVE,
    A_AMMO,
    A_BLAST,
    A_COL,
    A_ROW,
    B_BLAST,
    B_COL,
    B_LIFE,
    B_OWNER,
    B_ROW,
    M_BOMBS,
)

ME = 0


def _same(a, b) -> bool:
    return all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def _hide_under_fog(games: Games, n: int) -> None:
    """Change game `n` where agent ME cannot see: every fogged wooden cell becomes Passage, and
    a bomb appears on a fogged free cell."""
    view = games.obs.board[n, ME] != Item.FOG
    board = games.state.board[n]
    board[(board == Item.WOOD) & ~view] = Item.PASSAGE
    r, c = np.argwhere((board == Item.PASSAGE) & ~view)[0]
    k = games.state.meta[n, M_BOMBS]
    games.state.bombs[n, k, [B_ROW, B_COL, B_OWNER, B_LIFE, B_BLAST]] = [r, c, 1, 9, 2]
    games.state.meta[n, M_BOMBS] = k + 1
    board[r, c] = Item.BOMB
    games.observe()


def test_a_state_differing_under_the_fog_gives_the_same_moves():
    """Two copies of a game, the second changed under agent 0's fog after 12 steps; while agent
    0's observations agree, so do its moves (the others play the same moves in both)."""
    games = Games(2, TEAM_PRESET)
    games.reset([7, 7])
    agents = [SearchAgent(), SearchAgent()]
    for agent in agents:
        agent.reset(ME, int(TEAM_PRESET.game_type), np.random.default_rng(1))
    others = np.random.default_rng(2)
    compared = 0
    for step in range(40):
        if step == 12:
            _hide_under_fog(games, 1)
            assert not np.array_equal(games.state.board[0], games.state.board[1])
        mine = [games.obs.select(n, ME) for n in range(2)]
        if not _same(*mine) or games.done.any() or not games.alive[:, ME].all():
            break
        moves = [agent.act(obs) for agent, obs in zip(agents, mine, strict=True)]
        assert moves[0] == moves[1]
        compared += step >= 12
        actions = np.zeros((2, 4), np.int64)
        actions[:, 1:] = others.integers(0, 5, 3)  # the same moves, no bombs, in both games
        actions[:, ME] = moves
        games.step(actions)
    assert compared >= 3


def test_a_bomb_seen_then_fogged_is_believed_where_it_was_with_its_life_run_down():
    games = Games(1, TEAM_PRESET)
    games.reset([3])
    obs = games.obs.select(0, ME)
    memory = np.zeros(SearchAgent().memory.shape[1], np.int64)
    life = obs.bomb_life.copy()
    blast = obs.bomb_blast_strength.copy()
    life[2, 2], blast[2, 2] = 9, 3
    fields = (obs.board, blast, life, obs.bomb_moving_direction, obs.flame_life)
    remember(*fields, obs.position.astype(np.int64), ME, 10, memory)
    fogged = obs.board.copy()
    fogged[2, 2] = Item.FOG
    later = (fogged, np.zeros_like(blast), np.zeros_like(life), obs.bomb_moving_direction,
             obs.flame_life)
    belief = empty_belief()
    rebuild(*later, obs.position.astype(np.int64), 1, 2, 0, obs.alive, ME, 14, 5, memory,
            belief[0], belief[1], belief[2], belief[3], belief[5])
    assert belief[0][2, 2] == Item.BOMB and belief[5][M_BOMBS] == 1
    assert belief[2][0, [B_ROW, B_COL, B_LIFE, B_BLAST]].tolist() == [2, 2, 5, 3]


def test_a_seeded_match_replays_exactly():
    spec = MatchSpec("search_fast", "simple", games=4, seed=3)
    first = play_match(spec, workers=1)
    assert play_match(spec, workers=1) == first
    assert play_match(MatchSpec("search_fast", "simple", 4, seed=4), workers=1) != first


def test_it_beats_simple_agent_in_a_short_seeded_match():
    summary = summarise(play_match(MatchSpec("search", "simple", games=24, seed=0), workers=1))
    assert summary["win"] >= 0.6 and summary["loss"] <= 0.25, summary


@pytest.mark.parametrize("line, message", [
    ("depth = 7", r"search.toml: depth must be in 1\.\.3, got 7"),
    ("horizon = 4", r"search.toml: horizon must be in 10\.\.20, got 4"),
    ("recall = -1", r"search.toml: recall must be in 0\.\.800, got -1"),
    ('depth = "2"', r"search.toml: depth must be a int, got '2'"),
])
def test_a_bad_effort_names_the_file_key_and_value(tmp_path, line, message):
    path = tmp_path / "search.toml"
    path.write_text(f'kind = "search"\ndescription = "x"\n{line}\n')
    with pytest.raises(ValueError, match=message):
        make_agent(str(path))


def test_the_policy_files_set_the_effort():
    assert make_agent("search").effort == Effort(**resolve_policy("search").params)
    assert make_agent("search_fast").effort.depth < make_agent("search").effort.depth


def _open_state(agents: dict, blast: int = 2):
    """A believed state on an empty board (all Passage) with the given agents {seat: (row, col)}
    alive, each with one bomb of strength `blast`; the others absent."""
    board, table, bombs, flames, items, meta, radio = empty_belief()
    for seat, (r, c) in agents.items():
        table[seat, [A_ROW, A_COL, A_ALIVE, A_AMMO, A_BLAST]] = [r, c, 1, 1, blast]
        board[r, c] = Item.AGENT0 + seat
    return board, table, bombs, flames, items, meta, radio


def _values(state, me=ME, depth=2):
    hunt = np.zeros(state[0].shape, np.int64)
    return root_values(*state, me, int(TEAM_PRESET.game_type), depth, 10, hunt)


def test_a_move_onto_another_agents_cell_is_not_tried():
    values = _values(_open_state({ME: (5, 5), 1: (4, 5), 2: (5, 7)}))
    assert values[Action.UP] == -np.inf
    assert np.isfinite(values[[Action.STOP, Action.DOWN, Action.LEFT, Action.RIGHT]]).all()


def test_a_move_onto_a_cell_another_agent_could_enter_is_worth_less():
    """Standing on its own bomb, the agent must leave; a way out whose first cell the teammate
    could step onto too (both would bounce) is worth the mean of its value and Stop's."""
    def standing_on_a_bomb(agents):
        state = _open_state(agents)
        bombs, meta = state[2], state[5]
        bombs[0, [B_ROW, B_COL, B_OWNER, B_LIFE, B_BLAST]] = [5, 5, ME, 3, 2]
        meta[M_BOMBS] = 1
        return state

    alone = _values(standing_on_a_bomb({ME: (5, 5)}))
    assert alone[Action.UP] == alone[Action.DOWN] > alone[Action.STOP]
    crowded = _values(standing_on_a_bomb({ME: (5, 5), 2: (3, 5)}))
    assert crowded[Action.UP] < crowded[Action.DOWN]
    assert crowded[Action.UP] > crowded[Action.STOP]


def test_an_enemy_that_can_walk_up_and_trap_the_agent_is_a_threat():
    """In a dead end, an enemy of blast 3 two steps from the cell where its bomb seals the agent
    in gives a threat scenario the agent cannot survive; far away, it gives none."""
    def corridor(enemy_col):
        state = _open_state({ME: (5, 0), 1: (5, enemy_col)}, blast=3)
        board = state[0]
        board[4, :7] = board[6, :7] = Item.RIGID
        return state

    size = BOARD_SIZE
    fire = np.zeros((MAX_THREATS, 10, size, size), np.bool_)
    blocked = np.zeros_like(fire)
    home = np.array([5, 0], np.int64)
    game_type = int(TEAM_PRESET.game_type)
    near = _record_threats(*corridor(4), ME, game_type, 2, home, fire, blocked)
    trapped = [escape_cells(fire[k], blocked[k], 5, 0, 1) == 0 for k in range(near)]
    assert near > 0 and any(trapped) and not all(trapped)
    assert _record_threats(*corridor(10), ME, game_type, 2, home, fire, blocked) == 0


def test_a_bomb_whose_blast_covers_an_enemy_is_worth_laying():
    """On open ground, with an enemy next to it, laying a bomb now (then stepping out of its
    blast) is worth more than stepping away from the enemy first, whose bomb would miss it; with
    the enemy far away, bombing is worth no more than any move."""
    near = _values(_open_state({ME: (5, 5), 1: (5, 6)}))
    assert near[Action.BOMB] >= near[Action.UP] + 100
    far = _values(_open_state({ME: (5, 5), 1: (0, 10)}))
    assert far[Action.BOMB] == far[Action.UP] == far[Action.STOP]
