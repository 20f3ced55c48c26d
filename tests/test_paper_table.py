"""`benchmarks/paper_table.py`: a folder of cells is this command's or refused, a cell whose
records file lost its games is played again, and a bad --out is one line (issue 40, cases 7
and 12). Cells of 2 games against `static`, one worker."""

from __future__ import annotations

import gzip
from pathlib import Path

import pytest

from .conftest import benchmark_main


@pytest.fixture(scope="module")
def paper_table():
    return benchmark_main("paper_table")


def _args(out: Path, games: int = 2, seed: int = 0) -> list[str]:
    return ["--team", "static", "--opponents", "static", "--games", str(games), "--seed",
            str(seed), "--workers", "1", "--out", str(out)]


def test_cells_of_other_games_or_seed_are_refused_and_empty_ones_played_again(paper_table,
                                                                             tmp_path, capsys):
    out = tmp_path / "table"
    assert paper_table(_args(out)) == 0
    cell = out / "static__vs__static"
    records = out / "static__vs__static.jsonl.gz"
    assert len(gzip.decompress(records.read_bytes()).splitlines()) == 2
    played = {p.name: p.read_bytes() for p in out.iterdir()}
    capsys.readouterr()

    for games, seed in ((4, 0), (2, 1)):  # kept before: rc 0, nothing played
        assert paper_table(_args(out, games, seed)) == 2
        err = capsys.readouterr().err
        assert err.strip() == (
            f"error: {cell}.json: a cell of --games 2 --seed 0, not --games {games} --seed "
            f"{seed}; give another --out (or move the old cells aside)")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == played

    records.write_bytes(gzip.compress(b""))  # skipped before, then refused by report
    assert paper_table(_args(out)) == 0
    assert "== static__vs__static\n" in capsys.readouterr().out
    assert records.read_bytes() == played["static__vs__static.jsonl.gz"]
    assert paper_table(_args(out)) == 0  # finished: nothing played
    assert "==" not in capsys.readouterr().out


def test_an_out_that_is_a_file_is_one_line(paper_table, tmp_path, capsys):
    (tmp_path / "a_file").write_text("")
    for out in (tmp_path / "a_file", tmp_path / "a_file" / "table"):
        assert paper_table(_args(out)) == 2
        err = capsys.readouterr().err
        assert err.strip() == f"error: --out {out}: {tmp_path / 'a_file'} is a file, not a folder"
