"""Values of our TOML files (policy files, curricula) checked against the type their key wants,
by one rule for every file: a bool is not a number and a string is not a bool, but a float may be
written as an integer (`temperature = 2`, `gate_win = 1`), as TOML readers write whole numbers."""

from __future__ import annotations

from typing import Any


def fits(value: Any, kind: type) -> bool:
    """Whether a TOML value may stand for a key of type `kind`."""
    return type(value) is kind or (kind is float and type(value) is int)
