"""`benchmarks/threats.py` counts what a hand-made replay holds: one bomb laid with an enemy in
its cross who dies within the bomb's reach (a converted threat), one laid far from everyone,
and a kicked bomb that is not laid again; a trap chance taken and one missed."""

from __future__ import annotations

import gzip
import json

import pytest

from rllib_pommer.game.constants import Item

from .conftest import benchmark_main


def _agent(agent_id, position, alive=True):
    return {"agent_id": agent_id, "position": list(position), "is_alive": alive, "ammo": 1,
            "blast_strength": 2, "can_kick": False}


def _state(step, agents, bombs=(), rigid=()):
    """A whole state the engine loads: passages, `rigid` walls, the living agents drawn."""
    board = [[int(Item.PASSAGE)] * 11 for _ in range(11)]
    for row, col in rigid:
        board[row][col] = int(Item.RIGID)
    for bomb in bombs:
        board[bomb["position"][0]][bomb["position"][1]] = int(Item.BOMB)
    for agent in agents:
        if agent["is_alive"]:
            board[agent["position"][0]][agent["position"][1]] = int(Item.AGENT0) + agent["agent_id"]
    return {"step_count": step, "board": board, "agents": agents, "bombs": list(bombs),
            "flames": [], "items": []}


def _write(path, game):
    with gzip.open(path, "wt") as f:
        f.write(json.dumps(game) + "\n")
    return path


def _bomb(position, life, bomber=0, strength=3):
    return {"position": list(position), "bomber_id": bomber, "life": life,
            "blast_strength": strength, "moving_direction": None}


@pytest.fixture
def replay(tmp_path):
    far = [_agent(0, (1, 1)), _agent(1, (1, 3)), _agent(2, (9, 9)), _agent(3, (5, 6))]
    states = [
        _state(1, far, [_bomb((1, 1), 9)]),  # enemy 1 two cells away in line: a threat
        _state(2, far, [_bomb((1, 2), 8)]),  # kicked on: not laid again
        _state(5, [*far[:1], _agent(1, (1, 3), alive=False), *far[2:]]),
        _state(6, [*far[:1], _agent(1, (1, 3), alive=False), *far[2:]],
               [_bomb((9, 9), 9, bomber=2)]),  # nobody in line: no threat
    ]
    game = {"seats_a": [0, 2], "team": "a", "vs": "b", "steps": [{"state": s} for s in states],
            "final_info": {"result_name": "Win", "winners": [0, 2]}}
    return _write(tmp_path / "replays.jsonl.gz", game)


def test_threats_and_their_conversion(replay, capsys):
    assert benchmark_main("threats")([str(replay)]) == 0
    row = capsys.readouterr().out.strip().splitlines()[-1]
    # nearest living enemy 2, 2, then 7, 7 cells away once enemy 1 is dead
    # an open board: no enemy is ever one bomb from a trap
    assert row == "| a vs b | win | 1 | 0.50 | 4.5 | 1.0 / 0.0 | 1.0 | 1.00 | 0.0 | nan |", row


def test_a_trap_chance_is_counted_once_and_taken_when_a_bomb_follows(tmp_path, capsys):
    """Enemy 1 stands in a dead end whose way out agent 0 blocks: a chance. Agent 0 lays its
    bomb: taken, and from then on enemy 1 is trapped already, no chance. A second game where
    agent 0 walks away instead: a chance not taken."""
    walls = ((0, 4), (0, 6))
    others = [_agent(2, (10, 0)), _agent(3, (9, 9))]
    at_mouth = [_agent(0, (1, 5)), _agent(1, (0, 5)), *others]
    laid = [_bomb((1, 5), 9, strength=2)]
    trapped = [_agent(0, (2, 5)), _agent(1, (0, 5)), *others]
    taken = [_state(1, at_mouth, rigid=walls), _state(2, at_mouth, laid, walls),
             _state(3, trapped, [_bomb((1, 5), 8, strength=2)], walls)]
    missed = [_state(1, at_mouth, rigid=walls), _state(2, trapped, rigid=walls)]
    path = tmp_path / "traps.jsonl.gz"
    with gzip.open(path, "wt") as f:
        for outcome, states in (("Tie", taken), ("Tie", missed)):
            f.write(json.dumps({"seats_a": [0, 2], "team": "a", "vs": "b",
                                "steps": [{"state": s} for s in states],
                                "final_info": {"result_name": outcome, "winners": []}}) + "\n")
    assert benchmark_main("threats")([str(path)]) == 0
    row = capsys.readouterr().out.strip().splitlines()[-1]
    assert row.endswith("| 1.0 | 0.50 |"), row  # 2 chances in 2 games, 1 taken


def test_a_missing_file_is_one_line(tmp_path, capsys):
    assert benchmark_main("threats")([str(tmp_path / "none.jsonl")]) == 2
    assert capsys.readouterr().err.startswith("error: no replays file")
