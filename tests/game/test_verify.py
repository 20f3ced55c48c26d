"""Fidelity: every public reference game replays through our engine with zero mismatches."""

from __future__ import annotations

import copy
import itertools

from rllib_pommer.game.records import read_games
from rllib_pommer.game.verify import verify_game
from rllib_pommer.replay import main


def test_public_reference_games_replay_without_mismatch(public_games, capsys):
    exit_code = main(["verify", str(public_games)])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last == "verified 170 games, 19969 steps, 0 mismatches"
    assert exit_code == 0


def test_recorded_radio_games_replay_without_mismatch(radio_games, capsys):
    """The 40 TeamRadio games, replayed with their words: states with `radio_from_agent`,
    rewards, done, info and all four observations with `message`."""
    exit_code = main(["verify", str(radio_games)])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last == "verified 40 games, 4717 steps, 0 mismatches"
    assert exit_code == 0


def test_a_changed_word_is_reported_in_the_state_and_the_teammates_message(radio_games):
    record = next(read_games(radio_games))
    step = 7
    sender = next(a for a, action in enumerate(record["steps"][step]["full_actions"])
                  if isinstance(action, list))
    tampered = copy.deepcopy(record)
    tampered["steps"][step]["full_actions"][sender][1] ^= 1
    _, mismatches = verify_game(tampered)
    teammate = (sender + 2) % 4
    assert [(m.step, m.field) for m in mismatches] == [
        (step, f"state.radio_from_agent[{sender}][0]"),
        (step, f"observations[{teammate}].message[0]")]


def test_a_tampered_record_is_reported_with_seed_step_and_field(public_games):
    record = next(itertools.islice(read_games(public_games), 3, None))
    tampered = copy.deepcopy(record)
    positions = [record["initial_state"]["agents"][0]["position"]] + [
        s["state"]["agents"][0]["position"] for s in record["steps"]
    ]
    step = next(t for t in range(len(record["steps"])) if positions[t + 1] != positions[t])
    tampered["steps"][step]["actions"][0] = 0
    _, mismatches = verify_game(tampered)
    assert mismatches, "changing an action must change the replay"
    first = mismatches[0]
    assert (first.seed, first.step) == (record["seed"], step)
    assert first.field.startswith(("state", "observations"))
    assert str(first).startswith(f"game seed {record['seed']} step {step}: ")


def test_missing_files_are_named(tmp_path, capsys):
    assert main(["verify", str(tmp_path / "nope.jsonl.gz")]) == 2
    assert "nope.jsonl.gz: no such file" in capsys.readouterr().err
    assert main(["agree", str(tmp_path / "g.jsonl"), "--decisions", str(tmp_path / "d.json")]) == 2
    assert "d.json" in capsys.readouterr().err
