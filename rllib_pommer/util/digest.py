"""A file's SHA-256: how a record names the exact bytes it depends on (the weights a run began
with, the clone that played a DAgger shard), so that a file replaced later under the same name is
told apart."""

from __future__ import annotations

import hashlib
from pathlib import Path


def file_sha256(path: str | Path) -> str:
    """The SHA-256 hex digest of the file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()
