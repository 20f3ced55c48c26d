"""A policy served over loopback, played by our arena through our client, plays the in-process
match: same boards, same agent random streams, same records."""

from __future__ import annotations

import pytest

from rllib_pommer.arena.match import MatchSpec, play_match

from .conftest import games_played, http_policy


@pytest.mark.parametrize("served_side", ["team", "vs"])  # seats {0, 2}, then {1, 3}
def test_a_served_policy_plays_exactly_the_in_process_match(serve, tmp_path, served_side):
    remote = str(http_policy(tmp_path, [serve("simple"), serve("simple")]))
    local = dict(team="simple", vs="simple", games=1, seed=21, filters=("action",))
    served = play_match(MatchSpec(**{**local, served_side: remote}), workers=1)
    in_process = play_match(MatchSpec(**local), workers=1)
    assert games_played(served) == games_played(in_process)
    assert in_process[0].result != "tie"  # played out, not stalled


def test_one_server_for_two_seats_is_refused_by_name(serve, tmp_path):
    remote = str(http_policy(tmp_path, [serve("simple")]))
    with pytest.raises(ValueError, match="give each seat its own port"):
        play_match(MatchSpec(remote, "simple", games=1), workers=1)
