"""SimpleAgent against the reference's recorded decisions (docs/measurements.md)."""

from __future__ import annotations

import gzip
import json

import pytest

from rllib_pommer.agents.agreement import AgreementResult, format_line, measure_agreement

from ..conftest import DECISIONS
from ..conftest import PUBLIC_GAMES as GAMES


def test_agreement_with_the_reference_meets_the_goals():
    result = measure_agreement(GAMES, DECISIONS)
    print(format_line(result))
    assert result.decisions == 40046
    assert result.stable_decisions == 23922
    assert result.stable_agreement >= 0.99
    assert abs(result.agreement - result.reference_mean) <= 0.02
    assert abs(result.reference_mean - 0.7827) < 1e-4


def test_format_line():
    result = AgreementResult(0.78256, 40046, 0.99829, 23922, 0.7827)
    assert (
        format_line(result)
        == "agreement 0.7826 on 40046 decisions; stable 0.9983 on 23922 decisions"
    )


def test_files_that_do_not_fit_raise_a_clear_error(tmp_path):
    """A decisions row whose digit count differs from the seat's alive steps is refused."""
    with gzip.open(GAMES, "rt", encoding="utf-8") as lines:
        first_game = lines.readline()
    games = tmp_path / "games.jsonl.gz"
    with gzip.open(games, "wt", encoding="utf-8") as out:
        out.write(first_game)
    seed = json.loads(first_game)["seed"]
    decisions = tmp_path / "decisions.json"
    row = {"game_index": 0, "seed": seed, "agent_id": 0, "agree_of_8": "888"}
    decisions.write_text(json.dumps({"mean_agreement": 0.5, "rows": [row]}))
    with pytest.raises(ValueError, match="game_index 0, agent_id 0"):
        measure_agreement(games, decisions)
    row.update(game_index=1)
    decisions.write_text(json.dumps({"mean_agreement": 0.5, "rows": [row]}))
    with pytest.raises(ValueError, match="no game_index 1"):
        measure_agreement(games, decisions)


def test_any_policy_is_measured_by_the_same_ruler(tmp_path):
    """`--policy`: a policy file that plays SimpleAgent scores SimpleAgent's own agreement, and
    StaticAgent scores the share of recorded Stops, far below it."""
    simple = measure_agreement(GAMES, DECISIONS)
    copy = tmp_path / "my_simple.toml"
    copy.write_text('kind = "simple"\n')
    assert measure_agreement(GAMES, DECISIONS, policy=str(copy)) == simple
    static = measure_agreement(GAMES, DECISIONS, policy="static")
    assert static.decisions == simple.decisions
    assert 0.05 < static.agreement < 0.5 < simple.agreement
