"""Shared test fixtures: where the recorded reference data live (tests/reference/, in the repo,
so every clone proves the engine's fidelity; tests/reference/README.md says what each file is)."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
REFERENCE_DIR = REPO_ROOT / "tests" / "reference"
PUBLIC_GAMES = REFERENCE_DIR / "games_public.jsonl.gz"
RADIO_GAMES = REFERENCE_DIR / "radio" / "games_radio_public.jsonl.gz"
DECISIONS = REFERENCE_DIR / "simpleagent_decisions_public.json"
PAPER_TABLES = REFERENCE_DIR / "paper_tables.tex"


@pytest.fixture(scope="session")
def public_games() -> Path:
    return PUBLIC_GAMES


@pytest.fixture(scope="session")
def radio_games() -> Path:
    return RADIO_GAMES
