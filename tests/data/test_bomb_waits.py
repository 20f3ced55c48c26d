"""`benchmarks/bomb_waits.py` on SimpleAgent's games: it steps off the bomb it has just laid (its
rules lay a bomb only with an escape, then take it), and a missing dataset is named."""

from __future__ import annotations

from rllib_pommer.game.constants import Action

from ..conftest import benchmark_module


def test_simple_agent_steps_off_its_fresh_bomb(tiny_dataset, capsys):
    script = benchmark_module("bomb_waits")
    counts = script.waits(str(tiny_dataset))
    fresh = counts[9]
    assert fresh.sum() >= 20  # the six games lay bombs
    moves = fresh[[Action.UP, Action.DOWN, Action.LEFT, Action.RIGHT]].sum()
    assert moves / fresh.sum() >= 0.8
    assert counts[0].sum() > counts[1:].sum()  # most samples stand on no bomb
    assert counts[:, Action.BOMB][1:].sum() == 0  # no second bomb on a cell that holds one
    assert script.main([str(tiny_dataset)]) == 0
    assert "| 9 |" in capsys.readouterr().out


def test_a_missing_dataset_is_named(tmp_path, capsys):
    assert benchmark_module("bomb_waits").main([str(tmp_path / "nowhere")]) == 2
    assert "nowhere does not exist" in capsys.readouterr().err
