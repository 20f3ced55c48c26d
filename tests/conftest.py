"""Shared test fixtures: where the recorded reference data live (beside the repo, never copied)."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
REFERENCE_DIR = REPO_ROOT.parent / "shared" / "reference"
PUBLIC_GAMES = REFERENCE_DIR / "games_public.jsonl.gz"


@pytest.fixture(scope="session")
def public_games() -> Path:
    if not PUBLIC_GAMES.exists():
        pytest.skip(f"reference games not found at {PUBLIC_GAMES} (../shared/reference is absent)")
    return PUBLIC_GAMES
