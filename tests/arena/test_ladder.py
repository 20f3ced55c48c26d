"""The ladder: which pairs play, the fit on records whose outcome is known (order, Elo's scale,
a tie as half a win, reproducible intervals), and the command: a small real ladder that
resumes, adds only a new policy's pairs, and refuses records made with other games or seed,
damaged records and the pairs of a policy that changed since they were played."""

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
    PLAIN_LADDER_FILE,
    PLAYED_FILE,
    RECORDS_DIR,
    Ladder,
    default_policies,
    pair_path,
    policy_digest,
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
    """The pairs' records files in the ladder's folder, by name."""
    return {path.name: path.read_bytes()
            for path in sorted((folder / RECORDS_DIR).glob("*.jsonl.gz"))}


def _played(folder) -> dict:
    return json.loads((folder / RECORDS_DIR / PLAYED_FILE).read_text())


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
    assert _played(out) == {"games": 4, "seed": 0, "policies": {
        name: policy_digest(name) for name in ("simple", "simple_nobomb", "static")}}
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


def test_the_view_without_filters_fits_the_same_games_over_unfiltered_policies(tmp_path, capsys):
    ladder = Ladder(("simple_action", "static", "simple"), 2)
    assert ladder.without_filters().policies == ("simple", "static")
    assert Ladder(("simple_action", "static_jitter_action"), 2).without_filters() is None
    out = tmp_path / "ladder"
    assert main(["--policies", "static,simple,simple_action", "--games", "4", "--workers", "1",
                 "--bootstrap", "20", "--out", str(out)]) == 0
    full = json.loads((out / LADDER_FILE).read_text())
    plain = json.loads((out / PLAIN_LADDER_FILE).read_text())
    assert sorted(s["policy"] for s in plain["standings"]) == ["simple", "static"]
    assert [(p["team"], p["vs"]) for p in plain["pairs"]] == [("simple", "static")]
    (pair,) = [p for p in full["pairs"] if (p["team"], p["vs"]) == ("simple", "static")]
    assert plain["pairs"][0] == pair  # the same games, fitted again
    assert all(s["games"] == 4 for s in plain["standings"])
    table = (out / "ladder.md").read_text()
    assert "![the ladder (policies without filters)](ladder_no_filters.png)" in table
    assert table.count("| 1 | `") == 2
    assert PLAIN_LADDER_FILE in capsys.readouterr().out
    with Image.open(out / "ladder_no_filters.png") as image:
        assert np.asarray(image.convert("L")).std() > 10


LADDER = ["--policies", "static,simple_nobomb", "--games", "4", "--workers", "1",
          "--bootstrap", "20"]


@pytest.mark.parametrize("change, told", [
    (["--games", "6"], "were played with --games 4 --seed 0, and this ladder asks for --games 6 "
                       "--seed 0: resume with the same --games and --seed"),
    (["--seed", "1"], "were played with --games 4 --seed 0, and this ladder asks for --games 4 "
                      "--seed 1"),
])
def test_records_of_other_games_or_seed_are_refused_not_mixed(tmp_path, capsys, change, told):
    out = tmp_path / "ladder"
    assert main([*LADDER, "--out", str(out)]) == 0
    before, played = _files(out), _played(out)
    capsys.readouterr()
    assert main([*LADDER, "--out", str(out), *change]) == 2
    err = capsys.readouterr().err
    assert err.count("error:") == 1 and told in err and str(out) in err
    assert _files(out) == before and _played(out) == played


def test_a_pair_file_of_another_seed_is_refused_naming_it(tmp_path, capsys):
    """A folder without played.json or ladder.json: each pair file shows its own seed."""
    out = tmp_path / "ladder"
    path = pair_path(out, ("simple_nobomb", "static"))
    path.parent.mkdir(parents=True)
    write_records(path, games("simple_nobomb", "static", ["tie"] * 4))
    assert main([*LADDER, "--seed", "1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("error:") == 1 and f"{path}: games of seed 0, where this ladder plays " \
        f"seed 1: resume with the --seed they were played with" in err


@pytest.mark.parametrize("rows, told", [
    (lambda rows: rows[:1] + rows, "and game 0 appears 2 times: the file is cut short or "
                                   "damaged; delete it to play the pair again"),
    (lambda rows: rows[:3], "and game 3 is missing: the file is cut short or damaged"),
])
def test_a_pair_file_with_a_game_repeated_or_missing_is_damaged(tmp_path, capsys, rows, told):
    """The folder says which games its pairs play, so a file that lacks one is cut short, not
    a ladder of other settings."""
    out = tmp_path / "ladder"
    assert main([*LADDER, "--out", str(out)]) == 0
    path = pair_path(out, ("simple_nobomb", "static"))
    lines = gzip.decompress(path.read_bytes()).decode().splitlines(keepends=True)
    path.write_bytes(gzip.compress("".join(rows(lines)).encode()))
    capsys.readouterr()
    assert main([*LADDER, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("error:") == 1 and f"{path}: the pair plays games 0..3 {told}" in err


def _fake_arena(monkeypatch, interrupt_at: list[int] | None = None) -> list:
    """The ladder's matches replaced by games of known results; the pairs played, listed.
    Ctrl-C comes when `interrupt_at[0]` pairs were played."""
    played = []

    def arena(spec, workers, progress):
        if interrupt_at and len(played) == interrupt_at[0]:
            raise KeyboardInterrupt
        played.append((spec.team, spec.vs))
        return games(spec.team, spec.vs, ["win", "tie"] * (spec.games // 2), spec.seed)

    monkeypatch.setattr("rllib_pommer.ladder.play_match", arena)
    return played


def test_the_pairs_of_a_changed_policy_are_refused_naming_it(tmp_path, capsys, monkeypatch):
    """New weights or another way of acting is another policy: its kept games are refused
    (never rated as its play); a reworded description changes nothing; once its pair files
    are deleted it plays them again."""
    policies = tmp_path / "policies"
    (policies / "mine").mkdir(parents=True)
    (policies / "static.toml").write_text('kind = "static"\n')
    (policies / "mine" / "pi.pt").write_bytes(b"weights one")
    mine = policies / "mine.toml"
    mine.write_text('kind = "learned"\nweights = "mine/pi.pt"\ndescription = "mine"\n')
    monkeypatch.setenv("RLLIB_POMMER_POLICIES", str(policies))
    played = _fake_arena(monkeypatch)
    out = tmp_path / "ladder"
    argv = ["--policies", "mine,static", "--games", "2", "--bootstrap", "20", "--out", str(out)]
    assert main(argv) == 0 and played == [("mine", "static")]

    mine.write_text('kind = "learned"\nweights = "mine/pi.pt"\ndescription = "reworded"\n')
    assert main(argv) == 0 and len(played) == 1
    for change in (lambda: (policies / "mine" / "pi.pt").write_bytes(b"weights two"),
                   lambda: mine.write_text(mine.read_text() + "greedy = true\n")):
        change()
        capsys.readouterr()
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("error:") == 1 and "policy 'mine' changed since its pairs in" in err
        assert "delete its 1 pair files (mine__vs__static.jsonl.gz, ...) to play them" in err
        assert len(played) == 1

    pair_path(out, ("mine", "static")).unlink()
    assert main(argv) == 0 and played == [("mine", "static")] * 2
    assert main(argv) == 0 and len(played) == 2
    assert _played(out)["policies"]["mine"] == policy_digest("mine")


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
    interrupt_at = [1]
    played = _fake_arena(monkeypatch, interrupt_at)
    argv = ["--policies", "random,simple,static", "--games", "4", "--bootstrap", "20",
            "--out", str(tmp_path)]
    assert main(argv) == 130
    assert "interrupted: the pairs finished are kept" in capsys.readouterr().err
    assert list(_files(tmp_path)) == ["random__vs__simple.jsonl.gz"]
    assert not (tmp_path / LADDER_FILE).exists()
    interrupt_at[0] = -1
    assert main(argv) == 0
    assert "3 pairs of 3 policies: 1 played before, 2 to play" in capsys.readouterr().out
    assert played == [("random", "simple"), ("random", "static"), ("simple", "static")]
