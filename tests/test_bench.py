"""`python -m rllib_pommer.bench`: the job runs the measures that live beside the code they
measure (game/speed.py, agents/speed.py) and compares them with the reference's figures."""

from __future__ import annotations

import json

import numpy as np

from rllib_pommer import bench
from rllib_pommer.agents import speed as agents_speed
from rllib_pommer.game import speed as game_speed
from rllib_pommer.game.constants import RADIO_PRESET, TEAM_PRESET


def test_engine_and_agent_runs_measure_whole_games(monkeypatch):
    monkeypatch.setattr(game_speed, "GAMES_PER_RUN", 2)
    monkeypatch.setattr(agents_speed, "GAMES_PER_RUN", 2)
    for run in (game_speed.single_api_run, game_speed.batched_api_run,
                agents_speed.simple_objects_run, agents_speed.simple_batched_run):
        steps_per_s, games_per_s = run(0)
        assert steps_per_s > games_per_s > 0


def test_radio_runs_play_the_team_runs_games_with_words():
    team_seeds, moves = game_speed._run_actions(3, TEAM_PRESET)
    radio_seeds, actions = game_speed._run_actions(3, RADIO_PRESET)
    assert np.array_equal(team_seeds, radio_seeds) and np.array_equal(actions[..., 0], moves)
    assert actions.shape[-1] == 3 and actions[..., 1:].max() == 7


def test_bench_engine_prints_our_speed_beside_the_reference(monkeypatch, capsys):
    monkeypatch.setattr(game_speed, "GAMES_PER_RUN", 2)
    monkeypatch.setattr(bench, "RUNS", 2)
    assert bench.main(["engine", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    reference = json.loads(bench.REFERENCE_SPEED.read_text())["a_random_env_step"]
    assert result["reference_steps_per_s"] == reference["steps_per_s"]["median"]
    for api in ("single", "batched", "radio_single", "radio_batched"):
        assert len(result[f"{api}_steps_per_s_runs"]["runs"]) == 2
        assert result[f"{api}_ratio"] == result[f"{api}_steps_per_s"] / reference[
            "steps_per_s"]["median"]
    for api in ("single", "batched"):
        assert result[f"radio_{api}_vs_team"] == (result[f"radio_{api}_steps_per_s"]
                                                  / result[f"{api}_steps_per_s"])


def test_bench_search_times_each_search_policys_decisions(monkeypatch, capsys):
    monkeypatch.setattr(agents_speed, "SEARCH_GAMES", 2)
    monkeypatch.setattr(bench, "ARENA_GAMES", 2)
    assert bench.main(["search", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    for policy in bench.SEARCH_POLICIES:
        assert 0 < result[f"{policy}_p50_ms"] <= result[f"{policy}_p99_ms"] <= result[
            f"{policy}_max_ms"]
        assert result[f"{policy}_decisions"] > 2 * 20  # two seats, two games of 20+ steps
        assert result[f"{policy}_games_per_s"] > 0 and result[f"{policy}_arena_games_per_s"] > 0
