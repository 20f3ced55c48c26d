"""Options generated from settings dataclasses (util/cli_options.py): one per field, typed, with the
field's default, so `imitate` and `train` never retype a setting."""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import pytest

from rllib_pommer.imitation.bc import BCConfig
from rllib_pommer.util.cli_options import add_options, settings_from


@dataclass
class Example:
    inputs: list[Path]
    name: str
    fast: bool = True
    limit: int | None = None
    rate: float = 0.5


def _parse(settings: type, argv: list[str]):
    parser = argparse.ArgumentParser()
    add_options(parser, settings, {"rate": "how fast"})
    return settings_from(settings, parser.parse_args(argv))


def test_each_field_becomes_an_option_of_its_type_and_default():
    assert _parse(Example, ["--inputs", "a", "b", "--name", "x"]) == \
        Example([Path("a"), Path("b")], "x")
    assert _parse(Example, ["--inputs", "a", "--name", "x", "--no-fast", "--limit", "3",
                            "--rate", "0.25"]) == Example([Path("a")], "x", False, 3, 0.25)


@pytest.mark.parametrize("argv, error", [
    (["--name", "x"], "the following arguments are required: --inputs"),
    (["--inputs", "a", "--name", "x", "--limit", "many"], "--limit: invalid int value: 'many'"),
])
def test_missing_and_mistyped_options_are_usage_errors(capsys, argv, error):
    with pytest.raises(SystemExit) as exited:
        _parse(Example, argv)
    assert exited.value.code == 2 and error in capsys.readouterr().err


def test_imitate_options_give_bc_configs_defaults():
    assert _parse(BCConfig, ["--data", "d", "--out", "o"]) == BCConfig(data=[Path("d")],
                                                                       out=Path("o"))
