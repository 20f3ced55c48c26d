"""The one line a job's error takes: `error: <what went wrong>` on stderr, and another library's
exception cut down to fit it."""

from __future__ import annotations

import sys


def report_error(message: object, status: int = 2) -> int:
    """Print `error: <message>` on stderr and return `status`, the exit status the job returns
    (2 for input the user can fix, the default; 1 for a failure that is not theirs)."""
    print(f"error: {message}", file=sys.stderr)
    return status


def first_sentence(exc: BaseException) -> str:
    """The exception's type and the first sentence of its message. Libraries follow theirs with
    paragraphs of advice and logs (torch, after a failed load, suggests loading without
    `weights_only`, which would run whatever code the file holds; Ray names log folders)."""
    text = str(exc).strip()
    first = text.splitlines()[0].split(". ")[0] if text else ""
    return f"{type(exc).__name__}: {first}".rstrip(": ")
