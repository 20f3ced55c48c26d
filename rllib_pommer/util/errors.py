"""Another library's exception in the one line our errors take."""

from __future__ import annotations


def first_sentence(exc: BaseException) -> str:
    """The exception's type and the first sentence of its message. Libraries follow theirs with
    paragraphs of advice and logs (torch, after a failed load, suggests loading without
    `weights_only`, which would run whatever code the file holds; Ray names log folders)."""
    text = str(exc).strip()
    first = text.splitlines()[0].split(". ")[0] if text else ""
    return f"{type(exc).__name__}: {first}".rstrip(": ")
