"""A self-contained HTML replay viewer: one file, inline script and style, the game as JSON.

The page draws the same tiles as the PNG renderer (sent once as a PNG sheet in a data URI) in the
layer order `cell_layers` computed here, so the browser only blits: every view (the full board
and each agent's fog) is precomputed per step as one character per tile.
"""

from __future__ import annotations

import base64
import io
import json
import string
from importlib.resources import files
from pathlib import Path

from ..game.constants import NUM_AGENTS, Action
from .frames import Frame, frames
from .render import DEFAULT_CELL
from .tiles import cell_layers, tile_names, tile_sheet

TILE_CHARS = string.ascii_letters + string.digits
DATA_PLACEHOLDER = "__REPLAY_JSON__"


def encode_view(view_frames: list[Frame]) -> list[str]:
    """Per frame, the cells' tile stacks as characters, cells separated by '.'."""
    index = {name: TILE_CHARS[k] for k, name in enumerate(tile_names())}
    return [".".join("".join(index[name] for name in cell) for cell in cell_layers(frame))
            for frame in view_frames]


def _title(record: dict) -> str:
    info = record.get("final_info", {})
    result = info.get("result_name", "unfinished")
    if info.get("winners"):
        result += " for agents " + ", ".join(str(w) for w in info["winners"])
    mix = record.get("agent_mix_name") or record.get("agent_mix") or ""
    return f"{record.get('env_id', '')} · seed {record.get('seed', '?')} · {mix} · {result}"


def _sheet_uri(cell: int) -> str:
    buffer = io.BytesIO()
    tile_sheet(cell).save(buffer, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")


def viewer_data(record: dict, cell: int = DEFAULT_CELL) -> dict:
    """Everything the page needs, as one JSON-able dict."""
    full = frames(record)
    return {
        "title": _title(record),
        "size": len(record["initial_state"]["board"]),
        "cell": cell,
        "sheet": _sheet_uri(cell),
        "tiles": tile_names(),
        "tileChars": TILE_CHARS,
        "steps": [f.step for f in full],
        "agents": [[[a["is_alive"], a["ammo"], a["blast_strength"], a["can_kick"]]
                     for a in f.agents] for f in full],
        "actions": [None] + [[Action(a).name.capitalize() for a in s["actions"]]
                             for s in record["steps"]],
        "views": [{"id": "full", "label": "full board", "cells": encode_view(full)}]
        + [{"id": str(a), "label": f"as agent {a} sees it", "cells": encode_view(frames(record, a))}
           for a in range(NUM_AGENTS)],
    }


def viewer_html(record: dict, cell: int = DEFAULT_CELL) -> str:
    """The page for one game record."""
    template = files(__package__).joinpath("viewer.html").read_text(encoding="utf-8")
    # "</" would end the script element early; "<\/" is the same string to JSON.
    payload = json.dumps(viewer_data(record, cell), separators=(",", ":")).replace("</", "<\\/")
    return template.replace(DATA_PLACEHOLDER, payload)


def write_viewer(record: dict, out: str | Path, cell: int = DEFAULT_CELL) -> None:
    Path(out).write_text(viewer_html(record, cell), encoding="utf-8")
