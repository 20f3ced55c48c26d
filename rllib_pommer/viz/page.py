"""Browser pages that draw boards: what the replay viewer and the play page share.

A page gets the tiles once, as a PNG sheet in a data URI, and every board as one string: per cell
its tile stack (`tiles.cell_layers`, the order Pillow composes too) as one character per tile,
cells separated by '.'. The shared script `board.js` blits those stacks onto a canvas and fills
the agents' table, and `board.css` styles both pages, so the browser shows exactly what a PNG
shows and both pages draw it with the same code. A page template holds three placeholders, filled
by `page_html`: the shared style, the shared script, and the page's data as JSON.
"""

from __future__ import annotations

import base64
import io
import json
import string
from importlib.resources import files

from ..game.constants import Action
from .frames import Frame
from .render import DEFAULT_CELL
from .tiles import COLOURS, cell_layers, tile_names, tile_sheet

TILE_CHARS = string.ascii_letters + string.digits
STYLE_PLACEHOLDER = "/*__BOARD_CSS__*/"
SCRIPT_PLACEHOLDER = "/*__BOARD_JS__*/"
DATA_PLACEHOLDER = "__PAGE_JSON__"


def encode_frame(frame: Frame) -> str:
    """One board as the page receives it: each cell's tile stack as characters, '.' between."""
    index = {name: TILE_CHARS[k] for k, name in enumerate(tile_names())}
    return ".".join("".join(index[name] for name in cell) for cell in cell_layers(frame))


def _hex(colour: tuple[int, int, int]) -> str:
    return "#" + "".join(f"{v:02x}" for v in colour)


def _sheet_uri(cell: int) -> str:
    buffer = io.BytesIO()
    tile_sheet(cell).save(buffer, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")


def board_assets(size: int, cell: int = DEFAULT_CELL) -> dict:
    """What `pommerBoard` and `fillAgentTable` in board.js need, once per page."""
    return {
        "size": size,
        "cell": cell,
        "sheet": _sheet_uri(cell),
        "tiles": tile_names(),
        "tileChars": TILE_CHARS,
        "teamColours": [_hex(COLOURS["team_a"]), _hex(COLOURS["team_b"])],
    }


def agent_stats(agents: list[dict]) -> list[list]:
    """The agents' table rows: [alive, ammo, blast strength, can kick] per agent of a state."""
    return [[a["is_alive"], a["ammo"], a["blast_strength"], a["can_kick"]] for a in agents]


def action_labels(actions: list[int]) -> list[str]:
    return [Action(a).name.capitalize() for a in actions]


def page_html(package: str, template: str, data: dict) -> str:
    """Template `template` of `package` with the shared style and script and `data` inlined."""
    text = files(package).joinpath(template).read_text(encoding="utf-8")
    shared = files(__package__)
    # "</" would end the script element early; "<\/" is the same string to JSON.
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return (text.replace(STYLE_PLACEHOLDER, shared.joinpath("board.css").read_text("utf-8"))
            .replace(SCRIPT_PLACEHOLDER, shared.joinpath("board.js").read_text("utf-8"))
            .replace(DATA_PLACEHOLDER, payload))
