"""Kill credit: who killed whom, on crafted states with a known answer and on every recorded
reference game, against an oracle written here from the recorded bombs alone."""

from __future__ import annotations

import numpy as np
import pytest

from rllib_pommer.game.blast import mark_blast
from rllib_pommer.game.constants import Action, Item
from rllib_pommer.game.engine import Game, Games
from rllib_pommer.game.kills import death_cause, deaths_by_cause, killer_seats, kills_of_team
from rllib_pommer.game.records import config_of, read_games
from rllib_pommer.game.state import (
    A_ALIVE,
    A_COL,
    A_KICK,
    A_ROW,
    B_BLAST,
    B_COL,
    B_DIR,
    B_LIFE,
    B_OWNER,
    B_ROW,
    M_BOMBS,
)

FAR = {0: (0, 0), 1: (10, 0), 2: (10, 10), 3: (0, 10)}  # corners, out of every blast below


def _crafted(agents: dict[int, tuple[int, int]], bombs: list[tuple]) -> Game:
    """An empty board with agents at their cells (the rest in the corners) and bombs given as
    (owner, row, col, life, strength)."""
    game = Game()
    game.reset(0)
    state = game.dump()
    board = [[int(Item.PASSAGE)] * 11 for _ in range(11)]
    for seat, entry in enumerate(state["agents"]):
        row, col = agents.get(seat, FAR[seat])
        entry["position"] = [row, col]
        board[row][col] = int(Item.AGENT0) + seat
    state["bombs"] = []
    for owner, row, col, life, strength in bombs:
        state["bombs"].append({"position": [row, col], "bomber_id": owner, "life": life,
                               "blast_strength": strength, "moving_direction": None})
        board[row][col] = int(Item.BOMB)
    state.update(board=board, items=[], flames=[])
    return Game.from_state(state)


def _stop(game: Game, moves: dict[int, int] | None = None):
    actions = [int(Action.STOP)] * 4
    for seat, action in (moves or {}).items():
        actions[seat] = int(action)
    return game.step(actions)


def _killers(game: Game) -> list[list[int]]:
    return [killer_seats(mask) for mask in game.batch.killers[0]]


def test_a_bomb_kills_in_its_owners_name():
    game = _crafted({1: (5, 6)}, [(0, 5, 5, 1, 3)])
    _stop(game)
    assert not game.batch.alive[0, 1]
    assert _killers(game) == [[], [0], [], []]
    assert death_cause(1, game.batch.killers[0, 1]) == "enemy"


def test_a_chain_credits_the_bomb_that_set_it_off_and_its_own_owner():
    # Agent 2's bomb (life 1) reaches agent 0's bomb two cells right, which then reaches agent 1
    # two cells down; agent 2's own cross does not cover agent 1.
    game = _crafted({1: (7, 5)}, [(2, 5, 3, 1, 3), (0, 5, 5, 9, 3)])
    _stop(game)
    assert _killers(game)[1] == [0, 2]
    assert death_cause(1, game.batch.killers[0, 1]) == "enemy"


def test_overlapping_blasts_add_up_and_an_own_bomb_makes_it_a_suicide():
    # Agent 1 stands between its own bomb and agent 0's; both go off this step.
    game = _crafted({1: (5, 6)}, [(1, 5, 5, 1, 3), (0, 5, 8, 1, 3)])
    _stop(game)
    assert _killers(game)[1] == [0, 1]
    assert death_cause(1, game.batch.killers[0, 1]) == "self"


def test_a_teammates_bomb_is_a_team_kill():
    game = _crafted({0: (5, 6)}, [(2, 5, 5, 1, 3)])
    _stop(game)
    assert _killers(game)[0] == [2]
    assert death_cause(0, game.batch.killers[0, 0]) == "teammate"


def test_lingering_flames_keep_the_credit_of_the_blast_that_lit_them():
    # Agent 0's bomb (strength 2: one cell per ray) lights (5, 6); agent 1, next to it and out of
    # the blast, walks into the flames a step later.
    game = _crafted({1: (5, 7)}, [(0, 5, 5, 1, 2)])
    _stop(game)
    assert game.batch.alive[0, 1]
    assert game.dump()["board"][5][6] == int(Item.FLAMES)
    _stop(game, {1: Action.LEFT})
    assert not game.batch.alive[0, 1]
    assert _killers(game)[1] == [0]


def test_credit_starts_empty_and_resets_with_the_game():
    game = _crafted({1: (5, 6)}, [(0, 5, 5, 1, 3)])
    _stop(game)
    game.reset(3)
    assert not game.batch.killers.any() and not game.batch.burn.any()


def test_causes_and_tallies():
    died = [True, True, False, True]
    killers = [0b0010, 0b0010, 0, 0b0001]  # 0 by 1 (enemy), 1 by itself, 3 by 0 (enemy)
    assert [death_cause(s, killers[s]) for s in (0, 1, 3)] == ["enemy", "self", "enemy"]
    assert kills_of_team(0, died, killers) == 1  # agent 3, killed by agent 0's team
    assert kills_of_team(1, died, killers) == 1  # agent 0
    assert deaths_by_cause([1, 3], died, killers) == {"self": 1, "teammate": 0, "enemy": 1,
                                                      "unknown": 0}
    assert death_cause(2, 0) == "unknown"


def _exploded(before: np.ndarray, after: np.ndarray) -> list[np.ndarray]:
    """Bombs of `before` gone after the step: (owner, life) names a bomb, as one owner lays at
    most one bomb a step."""
    survivors = {(int(b[B_OWNER]), int(b[B_LIFE])) for b in after}
    return [b for b in before
            if b[B_LIFE] <= 1 or (int(b[B_OWNER]), int(b[B_LIFE]) - 1) not in survivors]


def _oracle_mask(board: np.ndarray, before: np.ndarray, gone: list, cell) -> int:
    """The credit of this step's fire on `cell`, recomputed from the bombs alone: detonation
    waves (timer bombs first, then every bomb some earlier wave's cross reaches), each bomb
    burning for its owner and for the waves that set it off."""
    crosses, credit = [], []
    for bomb in gone:
        cross = np.zeros_like(board)
        mark_blast(board, cross, bomb[B_ROW], bomb[B_COL], bomb[B_BLAST])
        crosses.append(cross)
        credit.append(1 << int(bomb[B_OWNER]))
    wave = [i for i, b in enumerate(gone) if b[B_LIFE] <= 1]
    done = set(wave)
    while wave:
        lit = 0
        reach = np.zeros_like(board)
        for i in wave:
            reach |= crosses[i]
            lit |= credit[i]
        fired = {}
        for i, bomb in enumerate(gone):
            if i not in done and reach[bomb[B_ROW], bomb[B_COL]]:
                fired[i] = sum(credit[j] for j in done
                               if crosses[j][bomb[B_ROW], bomb[B_COL]]) or lit
        for i in fired:
            credit[i] |= fired[i]
        wave = list(fired)
        done |= set(fired)
    mask = 0
    for cross, bits in zip(crosses, credit, strict=True):
        if cross[cell]:
            mask |= bits
    return mask


def test_recorded_reference_games_credit_every_death_as_the_oracle_does(public_games):
    """Every death in the 170 recorded games has a credit; where the oracle applies (no bomb
    moving or kickable, no flames on the cell before, every exploded bomb timed out or reached
    by this step's fire) the credit is the oracle's; and every death the reference statistics
    count as by the agent's own bomb is a "self" death here."""
    deaths = checked = own = 0
    for record in read_games(public_games):
        game = Game.from_state(record["initial_state"], config_of(record))
        state = game.state
        for entry in record["steps"]:
            board = state.board[0].copy()
            before = state.bombs[0, : state.meta[0, M_BOMBS]].copy()
            alive = state.agents[0, :, A_ALIVE] != 0
            kickers = (state.agents[0, :, A_KICK] != 0).any()
            game.step(entry["actions"])
            died = alive & (state.agents[0, :, A_ALIVE] == 0)
            if not died.any():
                continue
            gone = _exploded(before, state.bombs[0, : state.meta[0, M_BOMBS]])
            for seat in np.flatnonzero(died):
                deaths += 1
                mask = int(game.batch.killers[0, seat])
                assert mask, f"game seed {record['seed']}: agent {seat} died uncredited"
                cell = (state.agents[0, seat, A_ROW], state.agents[0, seat, A_COL])
                own_cross = any(_oracle_mask(board, before, [b], cell)
                                for b in gone if b[B_OWNER] == seat)
                if own_cross:  # the reference statistics' own-bomb rule
                    own += 1
                    assert death_cause(seat, mask) == "self"
                if (not kickers and not (before[:, B_DIR] != 0).any()
                        and board[cell] != Item.FLAMES):
                    expected = _oracle_mask(board, before, gone, cell)
                    assert mask == expected, (record["seed"], seat, killer_seats(mask),
                                              killer_seats(expected))
                    checked += 1
    assert deaths > 300 and checked > 100 and own > 100, (deaths, checked, own)


@pytest.mark.parametrize("seed", [0, 1])
def test_seeded_random_play_credits_every_death(seed):
    games = Games(16)
    games.reset(list(range(seed * 16, seed * 16 + 16)))
    rng = np.random.default_rng(seed)
    while not games.done.all():
        games.step(rng.integers(0, 6, (16, 4)))
    dead = ~games.alive
    assert dead.any()
    assert (games.killers[dead] != 0).all()
    assert (games.killers[~dead] == 0).all()
