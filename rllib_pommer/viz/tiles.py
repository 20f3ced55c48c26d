"""Cell pictures ("tiles"), drawn once with Pillow, shared by the PNG/GIF renderer and the viewer.

A board picture is a stack of tiles per cell (`cell_layers`), composed in the same order by Pillow
and by the HTML viewer's canvas, so the browser shows exactly what a PNG shows. Every tile shows
its key colour at `PROBE`, which is where tests read pixels.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..game.constants import NUM_AGENTS, Item
from .frames import Frame

PROBE = (0.5, 0.25)  # (x, y) as fractions of a cell
MAX_TIMER = 9  # bombs are laid with life 10 and tick in the same step, so they show 9..1
SUPERSAMPLE = 4  # tiles are drawn this much larger, then shrunk, for smooth edges

COLOURS = {
    "passage": (234, 228, 208),
    "rigid": (84, 90, 104),
    "wood": (168, 114, 62),
    "flames": (247, 136, 32),
    "fog": (62, 66, 78),
    "extra_bomb": (142, 68, 173),
    "incr_range": (34, 150, 90),
    "kick": (222, 172, 16),
    "bomb": (30, 30, 34),
    "team_a": (212, 52, 52),  # agents 0 and 2
    "team_b": (44, 100, 228),  # agents 1 and 3
}
POWER_UP_LABELS = {"extra_bomb": "B+", "incr_range": "R+", "kick": "K"}
BASE_TILE = {
    Item.PASSAGE: "passage",
    Item.RIGID: "rigid",
    Item.WOOD: "wood",
    Item.BOMB: "passage",  # the bomb itself comes from the bomb-life map
    Item.FLAMES: "flames",
    Item.FOG: "fog",
    Item.EXTRA_BOMB: "extra_bomb",
    Item.INCR_RANGE: "incr_range",
    Item.KICK: "kick",
    **{Item.AGENT0 + i: "passage" for i in range(NUM_AGENTS)},
}
GROUND_TILES = tuple(dict.fromkeys(BASE_TILE.values()))


def agent_colour(agent_id: int) -> tuple[int, int, int]:
    """Team colour: {0, 2} against {1, 3}."""
    return COLOURS["team_a"] if agent_id % 2 == 0 else COLOURS["team_b"]


def faded(colour: tuple[int, int, int], keep: float = 0.35) -> tuple[int, int, int]:
    """`colour` mixed into the passage colour (how dead agents are drawn)."""
    mixed = keep * np.array(colour) + (1 - keep) * np.array(COLOURS["passage"])
    return tuple(int(v) for v in np.round(mixed))


def tile_names() -> list[str]:
    timers = range(1, MAX_TIMER + 1)
    agents = range(NUM_AGENTS)
    return ([*GROUND_TILES] + [f"bomb{k}" for k in timers]
            + [f"badge{k}" for k in timers] + [f"agent{i}" for i in agents]
            + [f"dead{i}" for i in agents])


def cell_layers(frame: Frame) -> list[list[str]]:
    """Tile names per cell, row-major, bottom layer first: ground, bomb, agent, bomb timer badge
    (when an agent stands on its bomb), dead agents' markers (on visible cells they died on)."""
    dead_at: dict[tuple[int, int], list[int]] = {}
    for agent in frame.agents:
        if not agent["is_alive"]:
            dead_at.setdefault(tuple(agent["position"]), []).append(agent["agent_id"])
    layers = []
    size = frame.board.shape[0]
    for r in range(size):
        for c in range(size):
            code = int(frame.board[r, c])
            timer = min(int(frame.bomb_life[r, c]), MAX_TIMER)
            cell = [BASE_TILE[code]] + ([f"bomb{timer}"] if timer else [])
            if code >= Item.AGENT0:
                cell.append(f"agent{code - Item.AGENT0}")
                if timer:
                    cell.append(f"badge{timer}")
            elif code != Item.FOG:
                cell += [f"dead{i}" for i in dead_at.get((r, c), ())]
            layers.append(cell)
    return layers


@lru_cache(maxsize=8)
def font(pixels: int) -> ImageFont.FreeTypeFont:
    return ImageFont.load_default(size=pixels)


def _ground(draw: ImageDraw.ImageDraw, name: str, s: int) -> None:
    """Opaque ground tiles; power-ups sit on passage."""
    fill = COLOURS["passage"] if name in POWER_UP_LABELS else COLOURS[name]
    draw.rectangle((0, 0, s, s), fill=fill)
    edge = s // 12
    if name == "rigid":
        draw.polygon([(0, 0), (s, 0), (s - edge, edge), (edge, edge), (edge, s - edge), (0, s)],
                     fill=(124, 130, 146))
        draw.polygon([(s, s), (0, s), (edge, s - edge), (s - edge, s - edge), (s - edge, edge),
                      (s, 0)], fill=(54, 58, 68))
    elif name == "wood":
        dark = (120, 78, 40)
        draw.rectangle((0, 0, s - 1, s - 1), outline=dark, width=edge // 2)
        for y in (0.42, 0.7):
            draw.line((edge, y * s, s - edge, y * s), fill=dark, width=edge // 2)
        draw.line((0.62 * s, 0.42 * s, 0.62 * s, 0.7 * s), fill=dark, width=edge // 2)
    elif name == "flames":
        tongue = [(0.5, 0.3), (0.72, 0.56), (0.74, 0.74), (0.5, 0.92), (0.26, 0.74), (0.3, 0.52)]
        draw.polygon([(x * s, y * s) for x, y in tongue], fill=(255, 214, 72))
    elif name == "fog":
        draw.rectangle((0, 0, s - 1, s - 1), outline=(54, 58, 68), width=edge // 3)
    elif name in POWER_UP_LABELS:
        draw.rounded_rectangle((0.12 * s, 0.12 * s, 0.88 * s, 0.88 * s), radius=s // 6,
                               fill=COLOURS[name], outline=(255, 255, 255), width=edge // 2)
        draw.text((s / 2, 0.56 * s), POWER_UP_LABELS[name], fill=(255, 255, 255),
                  font=font(int(0.36 * s)), anchor="mm")


def _overlay(draw: ImageDraw.ImageDraw, name: str, s: int) -> None:
    """Transparent tiles drawn over the ground: bombs, timer badges, agents, dead markers."""
    kind, number = name.rstrip("0123456789"), name[len(name.rstrip("0123456789")):]
    white = (255, 255, 255, 255)
    if kind == "bomb":
        draw.line((0.62 * s, 0.24 * s, 0.78 * s, 0.08 * s), fill=(120, 90, 60, 255), width=s // 24)
        draw.ellipse((0.72 * s, 0.02 * s, 0.86 * s, 0.16 * s), fill=(255, 190, 40, 255))
        draw.ellipse((0.14 * s, 0.19 * s, 0.86 * s, 0.91 * s), fill=(*COLOURS["bomb"], 255))
        draw.text((s / 2, 0.56 * s), number, fill=white, font=font(int(0.4 * s)), anchor="mm")
    elif kind == "badge":
        draw.ellipse((0.6 * s, 0.6 * s, s - 1, s - 1), fill=(*COLOURS["bomb"], 255),
                     outline=white, width=s // 40)
        draw.text((0.8 * s, 0.8 * s), number, fill=white, font=font(int(0.26 * s)), anchor="mm")
    elif kind == "agent":
        draw.ellipse((0.15 * s, 0.15 * s, 0.85 * s, 0.85 * s),
                     fill=(*agent_colour(int(number)), 255), outline=white, width=s // 20)
        draw.text((s / 2, 0.52 * s), number, fill=white, font=font(int(0.42 * s)), anchor="mm")
    elif kind == "dead":
        draw.ellipse((0.15 * s, 0.15 * s, 0.85 * s, 0.85 * s),
                     fill=(*faded(agent_colour(int(number))), 255))
        for a, b in (((0.3, 0.38), (0.7, 0.78)), ((0.7, 0.38), (0.3, 0.78))):
            draw.line((a[0] * s, a[1] * s, b[0] * s, b[1] * s), fill=(40, 40, 40, 255),
                      width=s // 12)
    else:
        raise ValueError(f"unknown tile {name!r}")


@lru_cache(maxsize=4)
def tiles(cell: int) -> dict[str, Image.Image]:
    """Every tile as a `cell` x `cell` RGBA image, by name."""
    s = cell * SUPERSAMPLE
    out = {}
    for name in tile_names():
        image = Image.new("RGBA", (s, s), (0, 0, 0, 0))
        (_ground if name in GROUND_TILES else _overlay)(ImageDraw.Draw(image), name, s)
        out[name] = image.resize((cell, cell), Image.Resampling.LANCZOS)
    return out


def tile_sheet(cell: int) -> Image.Image:
    """All tiles side by side in `tile_names()` order (how the HTML viewer receives them)."""
    names = tile_names()
    sheet = Image.new("RGBA", (cell * len(names), cell), (0, 0, 0, 0))
    for k, name in enumerate(names):
        sheet.paste(tiles(cell)[name], (k * cell, 0))
    return sheet
