"""The repository stands alone: no tracked file cites a document outside it, and every
`docs/rules.md §N` citation names a section that docs/rules.md has.

A user's clone has no shared folder beside it and no project notes, so a citation of one is a dead
end.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RULES = ROOT / "docs" / "rules.md"

# Names of documents that live outside the repository, and paths that lead out of it, spelled
# in pieces so that this file does not cite them itself.
SHARED = "shared"
OUTSIDE_PARTS = (f"../{SHARED}", f"/work/{SHARED}", f"{SHARED}/docs/", f"{SHARED}/reference/",
                 "rllib" + "-notes", "pommerman" + "-rules", "reference " + "README")
OUTSIDE = re.compile("|".join(re.escape(part) for part in OUTSIDE_PARTS))
BINARY_SUFFIXES = {".pkl", ".pt", ".png", ".gif", ".gz", ".parquet", ".npz", ".npy"}
RULES_CITATION = re.compile(r"§(\d+(?:\.\d+)?)(?:-(\d+(?:\.\d+)?))?")


def tracked_text_files() -> list[Path]:
    """Every file git tracks here that is text (this test's own file excepted: it names the
    patterns it looks for)."""
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True)
    files = []
    for name in listed.stdout.decode().split("\0"):
        path = ROOT / name
        if not name or path.suffix in BINARY_SUFFIXES or not path.is_file():
            continue
        if path.resolve() == Path(__file__).resolve() or b"\0" in path.read_bytes()[:8192]:
            continue
        files.append(path)
    return files


def outside_citations(text: str) -> list[tuple[int, str]]:
    """(line number, line) of each line of `text` that cites something outside the repository."""
    return [(number, line.strip()) for number, line in enumerate(text.splitlines(), 1)
            if OUTSIDE.search(line)]


def rules_sections() -> set[str]:
    """The section numbers docs/rules.md has ('3', '3.7', ...), from its headings."""
    return set(re.findall(r"^#{2,3} (\d+(?:\.\d+)?)\.? ", RULES.read_text(), flags=re.M))


def cited_sections(text: str) -> list[str]:
    """The section numbers a file citing docs/rules.md names (both ends of a range '§3.4-3.7')."""
    return [number for match in RULES_CITATION.finditer(text) for number in match.groups()
            if number]


def test_the_detector_catches_each_kind_of_outside_citation():
    planted = (f"see {OUTSIDE_PARTS[0]}/docs/{OUTSIDE_PARTS[5]}.md §3\nfine line\n"
               f"({OUTSIDE_PARTS[4]} K2)\nas in the {OUTSIDE_PARTS[6]} §7\n")
    assert [number for number, _ in outside_citations(planted)] == [1, 3, 4]
    assert outside_citations("docs/rules.md §3.7 and tests/reference/README.md") == []
    assert cited_sections("docs/rules.md §3.4-3.7, §6") == ["3.4", "3.7", "6"]


@pytest.fixture(scope="module")
def files() -> list[Path]:
    try:
        return tracked_text_files()
    except (OSError, subprocess.CalledProcessError) as exc:  # a wheel or an unpacked sdist
        pytest.skip(f"not a git checkout ({exc})")


def test_no_tracked_file_cites_a_document_outside_the_repository(files):
    found = [f"{path.relative_to(ROOT)}:{number}: {line}"
             for path in files
             for number, line in outside_citations(path.read_text(errors="replace"))]
    assert not found, "citations of documents outside the repository:\n" + "\n".join(found)


def test_rules_citations_name_sections_that_exist(files):
    sections = rules_sections()
    assert {"1.4", "3", "3.13", "6.5", "8"} <= sections  # the headings parse
    missing = [f"{path.relative_to(ROOT)}: §{number}"
               for path in files if path != RULES and path.suffix == ".py"
               and "docs/rules.md" in (text := path.read_text(errors="replace"))
               for number in cited_sections(text) if number not in sections]
    assert not missing, "docs/rules.md has no such section:\n" + "\n".join(missing)
