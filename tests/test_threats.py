"""`benchmarks/threats.py` counts what a hand-made replay holds: one bomb laid with an enemy in
its cross who dies within the bomb's reach (a converted threat), one laid far from everyone,
and a kicked bomb that is not laid again."""

from __future__ import annotations

import gzip
import json

import pytest

from .conftest import benchmark_main


def _agent(agent_id, position, alive=True):
    return {"agent_id": agent_id, "position": list(position), "is_alive": alive}


def _state(step, agents, bombs=()):
    return {"step_count": step, "board": [[0] * 11 for _ in range(11)], "agents": agents,
            "bombs": list(bombs)}


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
    path = tmp_path / "replays.jsonl.gz"
    with gzip.open(path, "wt") as f:
        f.write(json.dumps(game) + "\n")
    return path


def test_threats_and_their_conversion(replay, capsys):
    assert benchmark_main("threats")([str(replay)]) == 0
    row = capsys.readouterr().out.strip().splitlines()[-1]
    # nearest living enemy 2, 2, then 7, 7 cells away once enemy 1 is dead
    assert row == "| a vs b | win | 1 | 0.50 | 4.5 | 1.0 / 0.0 | 1.0 | 1.00 |", row


def test_a_missing_file_is_one_line(tmp_path, capsys):
    assert benchmark_main("threats")([str(tmp_path / "none.jsonl")]) == 2
    assert capsys.readouterr().err.startswith("error: no replays file")
