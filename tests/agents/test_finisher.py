"""The `finish` kind: the search overrules the moves of the policy it names when they fall far
short of its own. A SuicideTeammate (a bomb on its first step, then standing on it) is taken off
its bomb, the seeded match replays exactly, and bad files are named."""

from __future__ import annotations

import pytest

from rllib_pommer.agents.finisher import Finisher
from rllib_pommer.agents.registry import make_agent
from rllib_pommer.arena.match import MatchSpec, play_match
from rllib_pommer.arena.records import summarise


def _policy(tmp_path, body: str) -> str:
    path = tmp_path / "finish.toml"
    path.write_text('kind = "finish"\ndescription = "test"\n' + body)
    return str(path)


def test_the_search_takes_a_suicide_teammate_off_its_bomb(tmp_path):
    finish = _policy(tmp_path, 'policy = "suicide"\n')
    assert isinstance(make_agent(finish), Finisher)
    plain = summarise(play_match(MatchSpec("suicide", "static", games=4, seed=3), workers=1))
    spec = MatchSpec(finish, "static", games=4, seed=3)
    records = play_match(spec, workers=1)
    saved = summarise(records)
    assert plain["own_bomb_deaths_a"] == 8  # every agent, every game
    assert saved["own_bomb_deaths_a"] == 0
    assert play_match(spec, workers=1) == records  # seeded: it replays exactly


def test_a_large_margin_never_overrules(tmp_path):
    finish = _policy(tmp_path, 'policy = "suicide"\nmargin = 1e12\n')
    summary = summarise(play_match(MatchSpec(finish, "static", games=2, seed=3), workers=1))
    assert summary["own_bomb_deaths_a"] == 4


@pytest.mark.parametrize("body, message", [
    ('policy = "nobody"\n', "finish.toml: .*nobody"),
    ('policy = "suicide"\nmargin = 0.0\n', "finish.toml: margin must be positive, got 0.0"),
    ('policy = "suicide"\ndepth = 9\n', r"finish.toml: depth must be in 1\.\.3, got 9"),
    ('margin = 5.0\n', "finish.toml: kind 'finish' needs key 'policy'"),
])
def test_a_bad_file_is_named(tmp_path, body, message):
    with pytest.raises(ValueError, match=message):
        make_agent(_policy(tmp_path, body))
