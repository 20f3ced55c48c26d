"""The arena: deterministic by seed, balanced seats, readable records, clear errors."""

from __future__ import annotations

import csv
import json
import subprocess
import sys

import pytest

from rllib_pommer.arena.match import MatchSpec, play_match, record_games
from rllib_pommer.arena.rates import wilson
from rllib_pommer.arena.records import summarise, write_records
from rllib_pommer.evaluate import main
from rllib_pommer.game.records import read_games
from rllib_pommer.replay import main as replay_main
from rllib_pommer.viz.matches import load_outcomes
from rllib_pommer.viz.tables import results_table


def test_same_seed_same_records_whatever_the_workers():
    spec = MatchSpec("simple", "random", games=6, seed=5)
    serial = play_match(spec, workers=1)
    parallel = play_match(spec, workers=2)
    assert serial == parallel
    assert play_match(MatchSpec("simple", "random", 6, seed=6), workers=1) != serial


def _heavy_after(code: str) -> list[str]:
    """Which of torch and requests a fresh interpreter has loaded after running `code`."""
    code += "\nimport sys; print([m for m in ('torch', 'requests') if m in sys.modules])"
    return json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True,
                                     text=True, check=True).stdout.replace("'", '"'))


def test_a_scripted_match_loads_no_torch_and_a_learned_one_does():
    match = "from rllib_pommer.arena.match import MatchSpec, play_match\n"
    assert _heavy_after(match + "play_match(MatchSpec('simple', 'static', 2), workers=1)") == []
    assert _heavy_after(match + "play_match(MatchSpec('imitation', 'static', 1), workers=1)") \
        == ["torch"]


def test_seats_alternate_unless_fixed():
    records = play_match(MatchSpec("static", "static", games=4, seed=1), workers=1)
    assert [r.seats_a for r in records] == [[0, 2], [1, 3], [0, 2], [1, 3]]
    fixed = play_match(MatchSpec("static", "static", 2, seed=1, fixed_seats=True), workers=1)
    assert [r.seats_a for r in fixed] == [[0, 2], [0, 2]]
    assert all(r.result == "tie" and r.length == 800 for r in records)


def test_short_match_statistics_fall_near_the_reference(public_games):
    reference = json.loads((public_games.parent / "simpleagent_stats.json").read_text())
    expected = reference["vs_StaticAgent"]
    spec = MatchSpec("simple", "static", games=120, seed=11, fixed_seats=True)
    summary = summarise(play_match(spec))
    # 120 games: compare with a margin of about three standard errors around the reference.
    assert abs(summary["win"] - expected["teamA_win_rate"]) < 0.08
    assert abs(summary["mean_length"] - expected["game_length_mean"]) < 35
    assert abs(summary["bombs_per_agent_a"] - expected["bombs_per_teamA_agent_per_game_mean"]) < 1.2
    assert summary["bombs_per_agent_b"] == 0


def test_cli_prints_summary_and_writes_records(tmp_path, capsys):
    jsonl, table = tmp_path / "games.jsonl", tmp_path / "games.csv"
    args = ["--team", "simple", "--vs", "static", "--games", "4", "--seed", "3", "--workers", "1"]
    assert main([*args, "--records", str(jsonl), "--json"]) == 0
    out = capsys.readouterr().out
    summary = json.loads(out.strip().splitlines()[-1])
    assert summary["games"] == 4
    assert abs(summary["win"] + summary["loss"] + summary["tie"] - 1) < 1e-9
    rows = [json.loads(line) for line in jsonl.read_text().splitlines()]
    assert [r["game"] for r in rows] == [0, 1, 2, 3]
    assert set(rows[0]) == {"game", "seed", "seats_a", "result", "length", "died",
                            "own_bomb_deaths", "bombs_laid", "team", "vs", "filters", "killers",
                            "variant"}
    assert rows[0]["variant"] == "team"
    assert (rows[0]["team"], rows[0]["vs"], rows[0]["filters"]) == ("simple", "static", [])
    assert main([*args, "--records", str(table)]) == 0
    with open(table) as f:
        assert [int(r["length"]) for r in csv.DictReader(f)] == [r["length"] for r in rows]


def test_recorded_replays_are_the_played_games_and_verify(tmp_path, capsys):
    replays = tmp_path / "replays.jsonl.gz"
    args = ["--team", "simple", "--vs", "random", "--games", "3", "--seed", "4", "--workers", "1",
            "--record", "2", "--replays", str(replays), "--with-observations", "--records",
            str(tmp_path / "games.jsonl")]
    assert main(args) == 0
    rows = [json.loads(line) for line in (tmp_path / "games.jsonl").read_text().splitlines()]
    games = list(read_games(replays))
    assert [g["game"] for g in games] == [0, 1]
    assert [g["num_steps"] for g in games] == [r["length"] for r in rows[:2]]
    assert all(g["has_observations"] and "observations" in g["steps"][0] for g in games)
    capsys.readouterr()
    assert replay_main(["verify", str(replays)]) == 0
    assert capsys.readouterr().out.strip().endswith("0 mismatches")


def test_radio_matches_play_the_team_games_and_replays_keep_the_words(tmp_path, capsys):
    """Words change no game: SimpleAgents (speaking or not) play TeamRadio exactly as Team. The
    replays record a speaker's [move, word, word], a silent or dead agent's plain move, and
    verify."""
    team = play_match(MatchSpec("simple", "simple", 4, seed=2), workers=1)
    radio = play_match(MatchSpec("simple_words", "simple", 4, seed=2, variant="radio"),
                       workers=1)
    assert [r.variant for r in radio] == ["radio"] * 4
    assert [{**vars(r), "variant": "", "team": ""} for r in radio] == [
        {**vars(r), "variant": "", "team": ""} for r in team]
    replays = tmp_path / "radio.jsonl.gz"
    args = ["--team", "simple_words", "--vs", "static", "--games", "2", "--seed", "4",
            "--workers", "1", "--variant", "radio", "--record", "2", "--replays", str(replays),
            "--with-observations"]
    assert main(args) == 0
    assert "2 TeamRadio games" in capsys.readouterr().out
    games = list(read_games(replays))
    assert {g["env_id"] for g in games} == {"PommeRadioCompetition-v2"}
    for game in games:
        states = [game["initial_state"]] + [step["state"] for step in game["steps"]]
        for before, step in zip(states, game["steps"], strict=False):
            speaks = [seat in game["seats_a"] and before["agents"][seat]["is_alive"]
                      for seat in range(4)]
            assert [isinstance(a, list) for a in step["full_actions"]] == speaks
            heard = [step["full_actions"][(a + 2) % 4] for a in range(4)]
            assert [o["message"] for o in step["observations"]] == [
                w[1:] if isinstance(w, list) else [0, 0] for w in heard]
    assert replay_main(["verify", str(replays)]) == 0
    assert capsys.readouterr().out.strip().endswith("0 mismatches")
    with pytest.raises(ValueError, match="the arena plays team games"):
        MatchSpec("simple", "simple", 1, variant="ffa")
    with pytest.raises(ValueError, match="unknown game preset 'radi'"):
        MatchSpec("simple", "simple", 1, variant="radi")


def _words_sent(replay: dict, seats) -> list[tuple]:
    """The words `seats` sent over a replay, step by step (a plain move: silence)."""
    return [tuple(a[1:]) if isinstance(a, list) else (0, 0)
            for step in replay["steps"] for s, a in enumerate(step["full_actions"]) if s in seats]


def test_a_radio_net_speaks_and_hears_in_the_arena_reproducibly(radio_policy):
    """A learned radio network plays TeamRadio through `radio_act`: its recorded words are not
    silence, the same seed gives the same games and words, and what its teammate said reaches
    its next observation. Its turns are decided in one forward pass per chunk, and a game's
    turns do not depend on its chunk (game 0 alone equals game 0 played beside game 1)."""
    spec = MatchSpec(str(radio_policy(greedy=False)), "simple", games=2, seed=3,
                     variant="radio")
    replays = record_games(spec, 2, observations=True)
    for replay in replays:
        words = _words_sent(replay, replay["seats_a"])
        assert len(set(words)) > 3 and all(0 <= w <= 7 for pair in words for w in pair)
        for step in replay["steps"]:
            said = [a[1:] if isinstance(a, list) else [0, 0] for a in step["full_actions"]]
            assert [o["message"] for o in step["observations"]] == [
                said[(seat + 2) % 4] for seat in range(4)]
    assert record_games(spec, 2, observations=True) == replays
    alone = record_games(spec, 1, observations=True)[0]
    assert alone["steps"] == replays[0]["steps"]
    other = record_games(MatchSpec(**{**vars(spec), "seed": 4}), 1)[0]
    assert _words_sent(other, other["seats_a"]) != _words_sent(replays[0], replays[0]["seats_a"])


def _exit_code(args) -> int:
    try:
        return main(args)
    except SystemExit as exc:  # argparse rejects bad values itself
        return exc.code


@pytest.mark.parametrize(("args", "message"), [
    (["--team", "nosuch", "--vs", "simple"], "unknown policy 'nosuch'; valid: "),
    (["--team", "simple", "--vs", "simple", "--filters", "jitter,magic"], "unknown filter 'magic'"),
    (["--team", "simple", "--vs", "simple", "--games", "0"],
     "argument --games: must be a positive integer, got '0'"),
    (["--team", "simple", "--vs", "static", "--record", "-1"],
     "argument --record: must be a non-negative integer, got '-1'"),
    (["--team", "simple", "--vs", "static", "--workers", "-1"],
     "argument --workers: must be a positive integer, got '-1'"),
    (["--team", "simple", "--vs", "static", "--seed", "-1"],
     "argument --seed: must be a non-negative integer, got '-1'"),
    (["--team", "simple", "--vs", "static", "--replays", "r.jsonl.gz"],
     "--replays r.jsonl.gz is written only with --record K"),
    (["--team", "simple", "--vs", "static", "--records", "/nodir/x.jsonl"],
     "--records /nodir/x.jsonl: folder /nodir does not exist"),
    (["--team", "simple", "--vs", "static", "--records", "/tmp"], "is a directory"),
    (["--team", "simple", "--vs", "static", "--record", "1", "--replays", "/nodir/r.jsonl.gz"],
     "--replays /nodir/r.jsonl.gz: folder /nodir does not exist"),
])
def test_bad_arguments_are_named(args, message, capsys):
    assert _exit_code(args) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("error:") == 1, err


def test_wilson_intervals_stay_within_0_and_1():
    for successes, n in ((0, 1), (0, 25), (25, 25), (1, 1), (0, 1000)):
        low, high = wilson(successes, n)
        assert 0.0 <= low <= successes / n <= high <= 1.0
    assert wilson(0, 25)[0] == 0.0 and wilson(25, 25)[1] == 1.0


def test_a_failed_write_after_the_match_still_prints_the_summary(tmp_path, capsys, monkeypatch):
    def disk_full(path, records):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("rllib_pommer.evaluate.write_records", disk_full)
    code = _exit_code(["--team", "simple", "--vs", "static", "--games", "2", "--workers", "1",
                       "--records", str(tmp_path / "r.jsonl")])
    captured = capsys.readouterr()
    assert code == 2 and "writing its output failed" in captured.err
    assert "simple vs static: 2 games" in captured.out and "win " in captured.out


def test_records_credit_every_death_to_a_cause_and_tables_show_kills(tmp_path):
    records = play_match(MatchSpec("simple", "simple", 16, seed=5), workers=1)
    for r in records:
        counts = r.kill_counts()
        dead_b = sum(r.died[s] for s in range(4) if s not in r.seats_a)
        dead_a = sum(r.died[s] for s in r.seats_a)
        # every death has exactly one cause: an enemy kill, a suicide or a team kill
        assert counts["kills_a"] + counts["suicides_b"] + counts["team_kills_b"] == dead_b
        assert counts["kills_b"] + counts["suicides_a"] + counts["team_kills_a"] == dead_a
        # own-bomb deaths are the engine's suicides
        assert counts["suicides_a"] == sum(r.own_bomb_deaths[s] for s in r.seats_a)
    summary = summarise(records)
    assert summary["kills_a_per_game"] + summary["kills_b_per_game"] > 0
    write_records(tmp_path / "m.jsonl", records)
    (outcomes,) = load_outcomes([tmp_path / "m.jsonl"]).values()
    assert outcomes.per_game()["kills_a"] == summary["kills_a_per_game"]
    assert f"kills {summary['kills_a_per_game']:.2f}" in results_table(
        "simple", load_outcomes([tmp_path / "m.jsonl"]))
