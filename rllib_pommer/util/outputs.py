"""Output files checked before the work that fills them: a match or a played game should not be
lost to a typo in the path it is written to."""

from __future__ import annotations

import os
from pathlib import Path


def check_output(path: Path | None, flag: str) -> None:
    """Refuse, naming `flag`, an output file that could not be written."""
    if path is None:
        return
    if path.is_dir():
        raise ValueError(f"{flag} {path} is a directory, not a file")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ValueError(f"{flag} {path}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise ValueError(f"{flag} {path}: not writable")


def check_output_dir(path: Path, flag: str) -> None:
    """Refuse, naming `flag`, an output folder that could not be made or written: one that is
    a file, or lies under a file or an unwritable folder."""
    existing = next((p for p in (path, *path.parents) if p.exists()), Path("."))
    if not existing.is_dir():
        raise ValueError(f"{flag} {path}: {existing} is a file, not a folder")
    if not os.access(existing, os.W_OK):
        raise ValueError(f"{flag} {path}: {existing} is not writable")
