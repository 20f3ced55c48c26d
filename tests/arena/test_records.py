"""The records file: one writer and its readers in arena/records.py."""

from __future__ import annotations

import gzip

import pytest

from rllib_pommer.arena.records import GameRecord, read_records, read_rows, write_records


def _records() -> list[GameRecord]:
    return [GameRecord(0, 3, [0, 2], "win", 120, [False, True, False, True],
                       [False, True, False, False], [4, 2, 5, 1], "simple", "static", ["action"],
                       [[], [1], [], [0]]),
            GameRecord(1, 3, [1, 3], "tie", 800, [False] * 4, [False] * 4, [9, 8, 7, 6],
                       "simple", "static", ["action"], [[], [], [], []], "radio")]


@pytest.mark.parametrize("name", ["m.jsonl", "m.jsonl.gz", "m.csv"])
def test_records_read_back_as_written(tmp_path, name):
    write_records(tmp_path / name, _records())
    assert read_records(tmp_path / name) == _records()
    assert [row["result"] for row in read_rows(tmp_path / name)] == ["win", "tie"]


def test_a_row_that_is_no_record_is_named(tmp_path):
    path = tmp_path / "m.jsonl.gz"
    path.write_bytes(gzip.compress(b'{"game": 0, "result": "win"}\n'))
    assert read_rows(path) == [{"game": 0, "result": "win"}]
    with pytest.raises(ValueError, match=r"m.jsonl.gz: not an arena records file \(no 'seed'\)"):
        read_records(path)
    path.write_bytes(gzip.compress(b'[1, 2]\n'))
    with pytest.raises(ValueError, match=r"m.jsonl.gz:1: a records row is a JSON object, got list"):
        read_records(path)
