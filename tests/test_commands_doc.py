"""docs/commands.md says what the code does: its records table names every column the arena
writes, and any count of the default ladder it gives is the one the code plays."""

from __future__ import annotations

import dataclasses
import re

from rllib_pommer.arena.ladder import default_policies
from rllib_pommer.arena.records import GameRecord

from .conftest import REPO_ROOT

COMMANDS = (REPO_ROOT / "docs" / "commands.md").read_text()


def _section(title: str) -> str:
    start = COMMANDS.index(f"### {title}\n")
    end = COMMANDS.find("\n### ", start + 1)
    return COMMANDS[start:end if end >= 0 else None]


def test_the_records_table_names_every_column():
    rows = [line for line in _section("The arena's records").splitlines()
            if line.startswith("| `")]
    named = [name for row in rows for name in re.findall(r"`(\w+)`", row.split("|")[1])]
    assert named == [field.name for field in dataclasses.fields(GameRecord)]


def test_a_count_of_the_default_ladder_is_the_one_it_plays():
    n = len(default_policies())
    for policies, pairs in re.findall(r"(\d+) policies, (\d+) pairs", _section("The ladder")):
        assert (int(policies), int(pairs)) == (n, n * (n - 1) // 2)
