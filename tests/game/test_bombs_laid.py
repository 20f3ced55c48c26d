"""The engine's count of the bombs each agent lays (`Games.laid`): on crafted states, and on
every recorded reference game against the laying rule applied to the recorded states alone."""

from __future__ import annotations

import numpy as np

from rllib_pommer.game.constants import Action
from rllib_pommer.game.engine import Game
from rllib_pommer.game.records import config_of, read_games
from rllib_pommer.game.state import A_ALIVE, A_AMMO, A_COL, A_ROW, B_COL, B_ROW, M_BOMBS

from .test_kills import _crafted, _stop


def test_a_bomb_counts_once_laid_and_not_without_ammo_or_on_a_bomb():
    game = _crafted({0: (5, 5)}, [])
    game.state.agents[0, 0, A_AMMO] = 2
    game.state.agents[0, 2, A_AMMO] = 0
    _stop(game, {0: Action.BOMB, 2: Action.BOMB})
    assert game.batch.laid[0].tolist() == [1, 0, 0, 0]
    _stop(game, {0: Action.BOMB})  # ammo left, but it stands on the bomb it just laid
    assert game.batch.laid[0].tolist() == [1, 0, 0, 0]
    assert game.state.agents[0, 0, A_AMMO] == 1
    game.reset(3)
    assert not game.batch.laid.any()


def test_recorded_reference_games_count_the_bombs_the_laying_rule_lays(public_games):
    """A living agent lays a bomb on a step whose action is Bomb when it has ammo and no bomb
    lies on its cell (docs/rules.md), read from the recorded states before each step."""
    total = 0
    for record in read_games(public_games):
        game = Game.from_state(record["initial_state"], config_of(record))
        state = game.state
        expected = np.zeros(4, np.int64)
        for entry in record["steps"]:
            agents = state.agents[0].copy()
            bombs = state.bombs[0, : state.meta[0, M_BOMBS]]
            cells = {(int(b[B_ROW]), int(b[B_COL])) for b in bombs}
            for seat, action in enumerate(entry["actions"]):
                move = action[0] if isinstance(action, list) else action
                if (move == Action.BOMB and agents[seat, A_ALIVE] and agents[seat, A_AMMO] > 0
                        and (int(agents[seat, A_ROW]), int(agents[seat, A_COL])) not in cells):
                    expected[seat] += 1
            game.step(entry["actions"])
        assert game.batch.laid[0].tolist() == expected.tolist(), record["seed"]
        total += int(expected.sum())
    assert total > 2500, total  # 3,007 bombs in the 170 games
