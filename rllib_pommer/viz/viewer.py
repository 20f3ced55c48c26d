"""A self-contained HTML replay viewer: one file, inline script and style, the game as JSON.

Every view (the full board and each agent's fog) is precomputed per step as encoded tile stacks
(`page.encode_frame`), so the browser only blits them with the board script it shares with the
play page.
"""

from __future__ import annotations

from pathlib import Path

from ..game.constants import NUM_AGENTS
from .frames import Frame, frames
from .page import action_labels, agent_stats, board_assets, encode_frame, page_html
from .render import DEFAULT_CELL


def encode_view(view_frames: list[Frame]) -> list[str]:
    """Per frame, the cells' tile stacks as characters, cells separated by '.'."""
    return [encode_frame(frame) for frame in view_frames]


def _title(record: dict) -> str:
    info = record.get("final_info", {})
    result = info.get("result_name", "unfinished")
    if info.get("winners"):
        result += " for agents " + ", ".join(str(w) for w in info["winners"])
    forfeit = record.get("forfeit")
    if forfeit:
        result += f" · agent {forfeit['seat']} forfeited at step {forfeit['step']}"
    mix = record.get("agent_mix_name") or record.get("agent_mix") or ""
    return f"{record.get('env_id', '')} · seed {record.get('seed', '?')} · {mix} · {result}"


def viewer_data(record: dict, cell: int = DEFAULT_CELL) -> dict:
    """Everything the page needs, as one JSON-able dict."""
    full = frames(record)
    return {
        "title": _title(record),
        "board": board_assets(len(record["initial_state"]["board"]), cell),
        "steps": [f.step for f in full],
        "agents": [agent_stats(f.agents) for f in full],
        "actions": [None] + [action_labels(s["actions"]) for s in record["steps"]],
        # TeamRadio: per frame, each agent's last [word, word]; None in the other games
        "words": [f.words for f in full] if full[0].words is not None else None,
        "views": [{"id": "full", "label": "full board", "cells": encode_view(full)}]
        + [{"id": str(a), "label": f"as agent {a} sees it", "cells": encode_view(frames(record, a))}
           for a in range(NUM_AGENTS)],
    }


def viewer_html(record: dict, cell: int = DEFAULT_CELL) -> str:
    """The page for one game record."""
    return page_html(__package__, "viewer.html", viewer_data(record, cell))


def write_viewer(record: dict, out: str | Path, cell: int = DEFAULT_CELL) -> None:
    Path(out).write_text(viewer_html(record, cell), encoding="utf-8")
