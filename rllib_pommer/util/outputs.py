"""Output files checked before the work that fills them: a match or a played game should not be
lost to a typo in the path it is written to, and a user's existing file (a policy file, earlier
records, another output of the same command) is never replaced unless the user asks (`--force`)."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path


def check_output(path: Path | None, flag: str, force: bool = False,
                 suffixes: Sequence[str] = ()) -> None:
    """Refuse, naming `flag`, an output file that could not be written, whose name ends in none
    of `suffixes` (when given: the kinds of file the writer makes), or that exists while
    `force` is false."""
    if path is None:
        return
    if path.is_dir():
        raise ValueError(f"{flag} {path} is a directory, not a file")
    if suffixes and not path.name.lower().endswith(tuple(suffixes)):
        raise ValueError(f"{flag} {path}: the name must end in {' or '.join(suffixes)}")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ValueError(f"{flag} {path}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise ValueError(f"{flag} {path}: not writable")
    if path.exists() and not force:
        raise ValueError(f"{flag} {path} exists; pass --force to replace it, or choose another "
                         f"name")


def check_distinct(outputs: Mapping[str, Path | None]) -> None:
    """Refuse two outputs of one command (flag -> path; None: not written) that name the same
    file, however it is spelled: the second would overwrite the first."""
    seen: dict[Path, str] = {}
    for flag, path in outputs.items():
        if path is None:
            continue
        where = path.resolve()
        if where in seen:
            raise ValueError(f"{seen[where]} and {flag} {path} are one file; give each its own")
        seen[where] = f"{flag} {path}"


def check_output_dir(path: Path, flag: str) -> None:
    """Refuse, naming `flag`, an output folder that could not be made or written: one that is
    a file, or lies under a file or an unwritable folder."""
    existing = next((p for p in (path, *path.parents) if p.exists()), Path("."))
    if not existing.is_dir():
        raise ValueError(f"{flag} {path}: {existing} is a file, not a folder")
    if not os.access(existing, os.W_OK):
        raise ValueError(f"{flag} {path}: {existing} is not writable")
