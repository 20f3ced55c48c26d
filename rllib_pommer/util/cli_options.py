"""Command-line options generated from a settings dataclass, so that each setting's name, type
and default are written once, in the dataclass (`imitation/bc.BCConfig` for `imitate`,
`curriculum/settings.RunSettings` for `train`), and the job adds only their help texts."""

from __future__ import annotations

import argparse
import dataclasses
import typing
from collections.abc import Mapping


def _element_type(hint) -> type:
    """`X` of `X`, `X | None` and `list[X]`."""
    args = typing.get_args(hint)
    if typing.get_origin(hint) is list:
        return args[0]
    return next((t for t in args if t is not type(None)), hint)


def add_options(parser: argparse.ArgumentParser, settings: type,
                helps: Mapping[str, str]) -> None:
    """One option `--field-name` per field of the dataclass `settings`: required where the field
    has no default (several values for a list), `--x/--no-x` for a bool, else typed with the
    field's default; `helps` gives the help texts by field name."""
    hints = typing.get_type_hints(settings)
    for field in dataclasses.fields(settings):
        flag = "--" + field.name.replace("_", "-")
        hint, help_text = hints[field.name], helps.get(field.name)
        kind = _element_type(hint)
        if field.default is dataclasses.MISSING:
            many = typing.get_origin(hint) is list
            parser.add_argument(flag, type=kind, required=True, help=help_text,
                                nargs="+" if many else None)
        elif hint is bool:
            parser.add_argument(flag, action=argparse.BooleanOptionalAction,
                                default=field.default, help=help_text)
        else:
            parser.add_argument(flag, type=kind, default=field.default,
                                help=help_text or f"default {field.default}")


def settings_from(settings: type, args: argparse.Namespace):
    """The dataclass `settings` made from the parsed options `add_options` added."""
    return settings(**{field.name: getattr(args, field.name)
                       for field in dataclasses.fields(settings)})


def _integer_from(text: str, minimum: int, what: str) -> int:
    """`text` as an integer of at least `minimum`; argparse's error names the option and the
    text as given (a count of "1e9" or "-1" is refused, never read as something else)."""
    try:
        value = int(text)
    except ValueError:
        value = minimum - 1
    if value < minimum:
        raise argparse.ArgumentTypeError(f"must be a {what} integer, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """An argparse type for counts that must be at least 1: games, processes."""
    return _integer_from(text, 1, "positive")


def non_negative_int(text: str) -> int:
    """An argparse type for seeds (numpy's seed sequences take no negative entropy) and counts
    that may be 0."""
    return _integer_from(text, 0, "non-negative")
