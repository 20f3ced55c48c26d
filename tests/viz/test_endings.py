"""How games ended, from record files (.jsonl and .csv): deaths per agent and by own bomb, the
losses to own bombs alone, ties at the step limit, per match, as the report tables them."""

from __future__ import annotations

from rllib_pommer.arena.records import GameRecord, write_records
from rllib_pommer.viz.endings import endings_table, load_endings
from rllib_pommer.viz.matches import Match


def _game(game, seats_a, result, length, died, own):
    return GameRecord(game, 0, seats_a, result, length, died, own, [1, 1, 1, 1], "ppo", "simple",
                      ["action"])


GAMES = [
    # A (seats 0, 2) loses: both of A dead by their own bombs.
    _game(0, [0, 2], "loss", 120, [True, False, True, False], [True, False, True, False]),
    # A (seats 1, 3) wins: B both dead, one by its own bomb; A's seat 1 killed by B.
    _game(1, [1, 3], "win", 300, [True, True, True, False], [False, False, True, False]),
    # A tie at the step limit, nobody dead.
    _game(2, [0, 2], "tie", 800, [False] * 4, [False] * 4),
    # A tie before it: the last agents of both teams died in one step.
    _game(3, [1, 3], "tie", 77, [True, True, True, True], [False, True, False, False]),
]


def test_endings_count_deaths_causes_and_ties_per_match(tmp_path):
    write_records(tmp_path / "a.jsonl", GAMES[:2])
    write_records(tmp_path / "b.csv", GAMES[2:])  # two files of one match, one of them .csv
    (summary,) = load_endings([tmp_path / "a.jsonl", tmp_path / "b.csv"]).values()
    assert summary["games"] == 4
    assert summary["dead_per_agent_a"] == 5 / 8  # game 0: 2, game 1: 1, game 3: 2
    assert summary["own_bomb_dead_per_agent_a"] == 3 / 8  # game 0: 2, game 3: seat 1
    assert summary["dead_per_agent_b"] == 4 / 8  # game 1: 2, game 3: 2
    assert summary["own_bomb_dead_per_agent_b"] == 1 / 8  # game 1: seat 2
    assert summary["loss_own_bombs_only"] == 1 / 4
    assert summary["tie"] == 2 / 4 and summary["tie_at_step_limit"] == 1 / 4
    table = endings_table("ppo", {Match("ppo", "action", "simple"): summary})
    assert "| SimpleAgent | action | 4 | 0.625 | 0.375 | 0.500 | 0.125 | 0.250 | 0.250 | " \
           "0.500 | 0.250 |" in table


def test_files_without_the_columns_are_left_out(tmp_path):
    bare = tmp_path / "ppo__vs__static.jsonl"
    bare.write_text('{"game": 0, "seats_a": [0, 2], "result": "win"}\n')
    assert load_endings([bare]) == {}
    assert endings_table("ppo", {}) == ""
