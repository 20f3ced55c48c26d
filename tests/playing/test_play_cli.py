"""`python -m rllib_pommer.play`: bad input is one line naming it, exit 2, before any serving."""

from __future__ import annotations

import pytest

from rllib_pommer.play import main


@pytest.mark.parametrize("args, message", [
    (["--vs", "nosuch"], "error: unknown policy 'nosuch'"),
    (["--seat", "4"], "error: seat must be one of 0..3, got 4"),
    (["--port", "70000"], "error: --port must be in 0..65535, got 70000"),
    (["--reconnect", "-1"], "error: --reconnect must be 0..3600 seconds, got -1.0"),
    (["--out", "no/such/folder/game.jsonl"], "error: --out no/such/folder/game.jsonl: folder "
                                             "no/such/folder does not exist"),
    (["--out", "kept.jsonl.gz"], "error: --out kept.jsonl.gz exists; pass --force to replace it"),
])
def test_bad_input_exits_2_naming_it(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "kept.jsonl.gz").write_bytes(b"an earlier game")
    assert main(["--team", "simple", "--vs", "static", "--port", "0", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(message) and "\n" not in err, err
    assert (tmp_path / "kept.jsonl.gz").read_bytes() == b"an earlier game"


def test_a_negative_seed_is_a_usage_error_naming_it(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--team", "simple", "--vs", "static", "--seed", "-1"])
    assert exit_info.value.code == 2
    assert "argument --seed: must be a non-negative integer, got '-1'" in capsys.readouterr().err


@pytest.mark.parametrize("value", ["fast", "0", "-1", "61", "nan"])
def test_a_bad_turn_time_is_a_usage_error(value, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--team", "simple", "--vs", "static", "--turn-time", value])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "argument --turn-time: turn time" in err and "is neither a number of seconds" in err
