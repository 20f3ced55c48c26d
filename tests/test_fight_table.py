"""`benchmarks/fight_table.py` is a command like the others: every name is checked before any
cell plays, a kept cell file that is not this table's is refused naming it, errors are one line
with exit 2, and cells are keyed by what they play (issue 50, cases 6-10 and 14). Cells of 2
games, one worker."""

from __future__ import annotations

import gzip
from pathlib import Path

import pytest

from .conftest import benchmark_main


@pytest.fixture(scope="module")
def fight_table():
    return benchmark_main("fight_table")


def _args(out: Path, teams=("static",), vs=("static",), games: int = 2) -> list[str]:
    return ["--teams", *teams, "--vs", *vs, "--games", str(games), "--workers", "1", "--out",
            str(out)]


def _one_error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and "Traceback" not in err, err
    return err.strip()


@pytest.mark.parametrize("teams, vs, message", [
    (["nosuch"], ["static"], "error: unknown policy 'nosuch'"),
    (["static"], ["nosuch"], "error: unknown policy 'nosuch'"),
    (["static", "nosuch"], ["static"], "error: unknown policy 'nosuch'"),  # after a good one
    (["static", "static"], ["static"], "error: --teams: static is listed twice"),
])
def test_names_are_checked_before_any_cell_plays(fight_table, tmp_path, capsys, teams, vs,
                                                 message):
    out = tmp_path / "table"
    assert fight_table(_args(out, teams, vs)) == 2
    assert _one_error(capsys).startswith(message)
    assert not out.exists()  # nothing played, nothing written


def test_a_snapshot_a_run_does_not_have_is_one_line(fight_table, tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    assert fight_table(_args(tmp_path / "table", [f"{run}@snapshot_9"])) == 2
    assert str(run) in _one_error(capsys)


def test_kept_cells_of_other_games_or_damaged_are_refused_with_exit_2(fight_table, tmp_path,
                                                                      capsys):
    out = tmp_path / "table"
    assert fight_table(_args(out)) == 0
    cell = out / "static__vs__static.jsonl.gz"
    played = cell.read_bytes()
    capsys.readouterr()
    assert fight_table(_args(out, games=4)) == 2
    assert _one_error(capsys) == (f"error: {cell}: holds 2 games of seed(s) [0], not games 0..3 "
                                  f"of seed 0; move it aside or pick another --out")
    for damaged, words in ((played[:len(played) // 2], "cut short"),
                           (gzip.compress(b"garbage\n"), "not JSON"),
                           (gzip.compress(b'{"game": 0}\n'), "not an arena records file")):
        cell.write_bytes(damaged)
        assert fight_table(_args(out)) == 2
        error = _one_error(capsys)
        assert error.startswith(f"error: {cell}") and words in error, error
    assert cell.read_bytes() == damaged  # never replaced


def test_cells_are_keyed_by_what_they_play(fight_table, tmp_path, capsys):
    """A policy file named like a policy of another kind gets its own cell and its own row."""
    other = tmp_path / "mine" / "simple.toml"
    other.parent.mkdir()
    other.write_text('kind = "suicide"\ndescription = "not SimpleAgent"\n')
    out = tmp_path / "table"
    assert fight_table(_args(out, ["simple", str(other)], ["static"])) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if "| static |" in line]
    assert [row.split(" | ")[0] for row in rows] == ["| simple", f"| {other}"]
    assert rows[0] != rows[1].replace(str(other), "simple")  # the suicide team plays otherwise
    assert len(list(out.glob("*.jsonl.gz"))) == 2
    assert fight_table(_args(out, [str(other)], ["static"])) == 0  # kept, not played again
    assert "games in" not in capsys.readouterr().err
