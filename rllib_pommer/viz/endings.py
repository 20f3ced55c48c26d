"""How a team's arena games ended, beside its win/loss/tie table: who died, how many of them by
their own bomb, which losses were the team's own bombs alone, and how many ties the step limit
decided. A win rate does not say whether a team loses to its opponents or to itself, nor whether
the games it does not win run out of time; these do, per match, from the same record files
(`arena/records.summarise` over their rows). Files written without those columns (the tables
need only `game`, `seats_a` and `result`) are left out.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from ..arena.records import game_record, read_rows, summarise
from .matches import VARIANTS, Match, match_of
from .paper import PAPER_OPPONENTS

NEEDED = frozenset({"seed", "length", "died", "own_bomb_deaths", "bombs_laid"})
COLUMNS = {  # summary key -> column heading
    "dead_per_agent_a": "ours dead per agent",
    "own_bomb_dead_per_agent_a": "… by own bomb",
    "dead_per_agent_b": "theirs dead per agent",
    "own_bomb_dead_per_agent_b": "… by own bomb",
    "loss": "losses",
    "loss_own_bombs_only": "… to own bombs alone",
    "tie": "ties",
    "tie_at_step_limit": "… at the step limit",
}


def load_endings(paths: Iterable[Path]) -> dict[Match, dict]:
    """Each match's summary over all its files' rows."""
    rows_by_match: dict[Match, list] = {}
    for path in paths:
        rows = read_rows(path)
        if all(set(row) >= NEEDED for row in rows):
            rows_by_match.setdefault(match_of(path, rows), []).extend(map(game_record, rows))
    return {match: summarise(records) for match, records in rows_by_match.items() if records}


def endings_table(team: str, endings: dict[Match, dict]) -> str:
    """One row per opponent and variant of `team`; every figure a share (of agents for the
    deaths, of games for the results). Empty if none of its files had the columns."""
    ours = sorted((m for m in endings if m.team == team),
                  key=lambda m: (m.vs, VARIANTS.index(m.variant)))
    if not ours:
        return ""
    lines = [f"#### How `{team}`'s games ended", "",
             "| opponent | variant | games | " + " | ".join(COLUMNS.values()) + " |",
             "|---" * (3 + len(COLUMNS)) + "|"]
    for match in ours:
        summary = endings[match]
        figures = " | ".join(f"{summary[key]:.3f}" for key in COLUMNS)
        lines.append(f"| {PAPER_OPPONENTS.get(match.vs, match.vs)} | {match.variant} | "
                     f"{summary['games']} | {figures} |")
    return "\n".join(lines)
