"""The ladder: which pairs play, the fit on records whose outcome is known (order, Elo's scale,
a tie as half a win, reproducible intervals), and the command: a small real ladder that
resumes, adds only a new policy's pairs, and refuses records made with other games or seed."""

from __future__ import annotations

import gzip
import json
import math

import numpy as np
import pytest
from PIL import Image

from rllib_pommer.agents.registry import policy_names
from rllib_pommer.arena.ladder import (
    LADDER_FILE,
    Ladder,
    default_policies,
    pair_path,
    rate,
)
from rllib_pommer.arena.match import play_match
from rllib_pommer.arena.records import GameRecord, write_records
from rllib_pommer.ladder import main


def games(a: str, b: str, results: list[str], seed: int = 0) -> list[GameRecord]:
    """Arena records of `a` (team A) against `b` with the given results for A."""
    return [GameRecord(game=g, seed=seed, seats_a=[0, 2] if g % 2 == 0 else [1, 3], result=r,
                       length=100, died=[False] * 4, own_bomb_deaths=[False] * 4,
                       bombs_laid=[0] * 4, team=a, vs=b) for g, r in enumerate(results)]


def standings(ladder: Ladder, results: dict) -> dict:
    return {s.policy: s for s in rate(ladder, {pair: games(*pair, rs)
                                               for pair, rs in results.items()})}


def test_pairs_do_not_depend_on_the_order_policies_are_listed_in():
    pairs = [("random", "simple"), ("random", "static"), ("simple", "static")]
    assert Ladder(("static", "simple", "random"), 2).pairs() == pairs
    assert Ladder(("random", "static", "simple"), 2).pairs() == pairs


def test_the_default_ladder_is_every_local_policy_and_each_learned_one_filtered():
    names = default_policies()
    assert set(policy_names()) <= set(names) and len(names) == len(set(names))
    assert {"ppo_team_jitter_action", "imitation_jitter_action"} <= set(names)
    assert "static_jitter_action" not in names  # filters are for learned policies


def test_certain_outcomes_order_the_ratings():
    """simple always beats static and random, static always beats random."""
    ladder = Ladder(("random", "simple", "static"), 50, bootstrap=100)
    ranked = standings(ladder, {("random", "simple"): ["loss"] * 50,
                                ("random", "static"): ["loss"] * 50,
                                ("simple", "static"): ["win"] * 50})
    simple, static, random = ranked["simple"], ranked["static"], ranked["random"]
    assert simple.rating > static.rating + 400 > random.rating + 800
    assert (simple.win, simple.loss, simple.tie, simple.games) == (100, 0, 0, 100)
    assert (static.win, static.loss) == (50, 50) and random.loss == 100
    assert abs(sum(s.rating for s in ranked.values())) < 1e-6  # centred


@pytest.mark.parametrize("results, points", [
    (["win"] * 76 + ["loss"] * 24, 400 * math.log10(0.76 / 0.24)),  # Elo's 200 points
    (["win"] * 70 + ["loss"] * 30, 147.2),
    (["win"] * 60 + ["loss"] * 20 + ["tie"] * 20, 147.2),  # a tie is half a win
    (["tie"] * 100, 0.0),
    (["loss"] * 40 + ["tie"] * 60, -147.2),  # a score of 0.3
])
def test_ratings_are_on_elos_scale_and_a_tie_is_half_a_win(results, points):
    ladder = Ladder(("simple", "static"), len(results) * 5, bootstrap=200)
    ranked = standings(ladder, {("simple", "static"): results * 5})
    gap = ranked["simple"].rating - ranked["static"].rating
    assert gap == pytest.approx(points, abs=2.0)  # the one virtual tie a pair moves it a little
    assert ranked["simple"].low <= ranked["simple"].rating <= ranked["simple"].high


def test_intervals_are_reproducible_and_narrow_with_more_games():
    def interval(n, seed):
        ladder = Ladder(("simple", "static"), 10 * n, seed, bootstrap=300)
        s = standings(ladder, {("simple", "static"): ["win", "win", "loss", "tie", "tie"] * 2 * n})
        return s["simple"].low, s["simple"].high

    assert interval(4, 0) == interval(4, 0)
    small, large = np.diff(interval(4, 0))[0], np.diff(interval(64, 0))[0]
    assert large < small / 2  # ~ 1 / sqrt(16)


def test_rating_needs_every_pair():
    ladder = Ladder(("random", "simple", "static"), 2)
    with pytest.raises(ValueError, match="pair random vs static has not been played"):
        rate(ladder, {("random", "simple"): games("random", "simple", ["win", "tie"])})


def _files(folder) -> dict:
    return {path.name: path.read_bytes() for path in sorted((folder / "records").iterdir())}


def test_a_ladder_plays_resumes_and_adds_only_new_pairs(tmp_path, capsys):
    out = tmp_path / "ladder"
    base = ["--games", "4", "--workers", "1", "--bootstrap", "50", "--out", str(out)]
    assert main(["--policies", "static,simple_nobomb,simple", *base]) == 0
    printed = capsys.readouterr().out
    assert "3 pairs of 3 policies: 0 played before, 3 to play (12 games)" in printed
    files = _files(out)
    assert sorted(files) == ["simple__vs__simple_nobomb.jsonl.gz",
                             "simple__vs__static.jsonl.gz", "simple_nobomb__vs__static.jsonl.gz"]
    # A pair's file is the arena's records of that match, so evaluate and report read it too;
    # gzipped without a timestamp, the same games are the same bytes.
    ladder = Ladder(("static", "simple_nobomb", "simple"), 4)
    write_records(tmp_path / "again.jsonl.gz", play_match(ladder.match(("simple", "static")), 1))
    assert (tmp_path / "again.jsonl.gz").read_bytes() == files["simple__vs__static.jsonl.gz"]
    data = json.loads((out / LADDER_FILE).read_text())
    assert (data["games_per_pair"], data["seed"], data["bootstrap"]) == (4, 0, 50)
    assert sorted(s["policy"] for s in data["standings"]) == ["simple", "simple_nobomb", "static"]
    assert all(s["games"] == 8 and s["low"] <= s["rating"] <= s["high"]
               for s in data["standings"])
    assert [p["win"] + p["loss"] + p["tie"] for p in data["pairs"]] == [4, 4, 4]
    table = (out / "ladder.md").read_text()
    assert "| 1 | `" in table and "| 3 | `" in table and "![the ladder](ladder.png)" in table
    with Image.open(out / "ladder.png") as image:
        assert np.asarray(image.convert("L")).std() > 10

    # The same command again, the policies in another order: nothing is played or changed.
    assert main(["--policies", "simple,static,simple_nobomb", *base]) == 0
    assert "3 played before, 0 to play" in capsys.readouterr().out
    assert _files(out) == files and json.loads((out / LADDER_FILE).read_text()) == data

    # A new policy plays its own pairs only.
    assert main(["--policies", "static,simple_nobomb,simple,random", *base]) == 0
    assert "6 pairs of 4 policies: 3 played before, 3 to play (12 games)" in \
        capsys.readouterr().out
    grown = _files(out)
    assert len(grown) == 6 and {name: grown[name] for name in files} == files


@pytest.mark.parametrize("change, told", [
    (["--games", "6"], "played with 4 games, seed 0; this ladder asks for 6 games a pair, seed 0"),
    (["--seed", "1"], "played with 4 games, seed 0; this ladder asks for 4 games a pair, seed 1"),
])
def test_records_of_other_games_or_seed_are_refused_not_mixed(tmp_path, capsys, change, told):
    out = tmp_path / "ladder"
    pair = ("simple_nobomb", "static")
    path = pair_path(out, pair)
    path.parent.mkdir(parents=True)
    write_records(path, games(*pair, ["tie"] * 4))
    before = path.read_bytes()
    argv = ["--policies", "static,simple_nobomb", "--games", "4", "--out", str(out), *change]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("error:") == 1 and told in err and str(path) in err
    assert path.read_bytes() == before and not (out / LADDER_FILE).exists()


def test_records_of_another_match_in_a_pairs_file_are_refused(tmp_path, capsys):
    out = tmp_path / "ladder"
    path = pair_path(out, ("simple_nobomb", "static"))
    path.parent.mkdir(parents=True)
    write_records(path, games("simple", "static", ["tie"] * 4))
    assert main(["--policies", "static,simple_nobomb", "--games", "4", "--out", str(out)]) == 2
    assert "not simple_nobomb vs static" in capsys.readouterr().err


@pytest.mark.parametrize("damage, told", [
    (lambda text: text.replace('"tie"', '"draw"', 1), "game 0: result 'draw' is not one of"),
    (lambda text: text[:-30], "simple_nobomb__vs__static.jsonl.gz:4"),  # a line cut short
    (lambda text: text.replace('"seed": 0, ', "", 1), "not an arena records file"),
    (None, "simple_nobomb__vs__static.jsonl.gz: damaged or cut short"),  # the gzip cut short
])
def test_a_damaged_pair_file_is_named(tmp_path, capsys, damage, told):
    out = tmp_path / "ladder"
    path = pair_path(out, ("simple_nobomb", "static"))
    path.parent.mkdir(parents=True)
    write_records(path, games("simple_nobomb", "static", ["tie"] * 4))
    if damage is None:
        path.write_bytes(path.read_bytes()[:-20])
    else:
        path.write_bytes(gzip.compress(damage(gzip.decompress(path.read_bytes()).decode())
                                       .encode()))
    assert main(["--policies", "static,simple_nobomb", "--games", "4", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("error:") == 1 and told in err and "Traceback" not in err


def test_an_interrupted_ladder_keeps_its_finished_pairs_and_resumes(tmp_path, capsys,
                                                                    monkeypatch):
    """Ctrl-C during the second pair: the first pair's file stays whole, the next run plays the
    other two pairs only."""
    played, interrupt_at = [], [1]

    def arena(spec, workers, progress):
        if len(played) == interrupt_at[0]:
            raise KeyboardInterrupt
        played.append((spec.team, spec.vs))
        return games(spec.team, spec.vs, ["win", "tie"] * (spec.games // 2), spec.seed)

    monkeypatch.setattr("rllib_pommer.ladder.play_match", arena)
    argv = ["--policies", "random,simple,static", "--games", "4", "--bootstrap", "20",
            "--out", str(tmp_path)]
    assert main(argv) == 130
    assert "interrupted: the pairs finished are kept" in capsys.readouterr().err
    assert [p.name for p in (tmp_path / "records").iterdir()] == ["random__vs__simple.jsonl.gz"]
    assert not (tmp_path / LADDER_FILE).exists()
    interrupt_at[0] = -1
    assert main(argv) == 0
    assert "3 pairs of 3 policies: 1 played before, 2 to play" in capsys.readouterr().out
    assert played == [("random", "simple"), ("random", "static"), ("simple", "static")]
