"""Pillow pictures of a recorded game: one step as a PNG, or every step as an animated GIF.

Each picture is a header (step, whose view, every agent's ammo, blast strength, kick or death, and
in TeamRadio the words it sent last) above the board composed from the shared tiles.
"""

from __future__ import annotations

from pathlib import Path

from PIL import Image, ImageDraw

from .frames import Frame, frames
from .tiles import cell_layers, font, tiles

DEFAULT_CELL = 40
HEADER_BG = (34, 38, 46)
HEADER_TEXT = (236, 236, 236)
HEADER_CELLS = 1.7  # header height in cells: a title line and two lines of agents


def agent_line(agent: dict, words: list[int] | None = None) -> str:
    """An agent's header text; `words`, in TeamRadio, the pair it sent in the frame's step."""
    said = f"  says {words[0]} {words[1]}" if words is not None else ""
    if not agent["is_alive"]:
        return "dead" + said
    kick = "  kick" if agent["can_kick"] else ""
    return f"ammo {agent['ammo']}  blast {agent['blast_strength']}{kick}{said}"


def _draw_header(image: Image.Image, frame: Frame, last_step: int, cell: int) -> None:
    draw = ImageDraw.Draw(image)
    text_font = font(max(10, int(0.3 * cell)))
    line = int(0.5 * cell)
    pad = cell // 5
    view = "full board" if frame.viewer is None else f"as agent {frame.viewer} sees it"
    draw.text((pad, pad), f"step {frame.step} / {last_step}", fill=HEADER_TEXT, font=text_font)
    draw.text((image.width - pad, pad), view, fill=HEADER_TEXT, font=text_font, anchor="ra")
    icon = line - 2
    for agent in frame.agents:
        i = agent["agent_id"]
        x, y = pad + (i % 2) * image.width // 2, pad + line * (1 + i // 2)
        image.alpha_composite(tiles(icon)[f"{'agent' if agent['is_alive'] else 'dead'}{i}"],
                              (x, y))
        words = frame.words[i] if frame.words is not None else None
        draw.text((x + icon + pad // 2, y + icon // 2), agent_line(agent, words),
                  fill=HEADER_TEXT, font=text_font, anchor="lm")


def draw_frame(frame: Frame, last_step: int, cell: int = DEFAULT_CELL) -> Image.Image:
    """The RGB picture of one frame; `last_step` is the game's final step (for the header)."""
    size = frame.board.shape[0]
    header = board_origin(cell)[1]
    image = Image.new("RGBA", (size * cell, header + size * cell), (*HEADER_BG, 255))
    tile_images = tiles(cell)
    for k, layers in enumerate(cell_layers(frame)):
        r, c = divmod(k, size)
        for name in layers:
            image.alpha_composite(tile_images[name], (c * cell, header + r * cell))
    _draw_header(image, frame, last_step, cell)
    return image.convert("RGB")


def board_origin(cell: int = DEFAULT_CELL) -> tuple[int, int]:
    """(x, y) pixel of the board's top-left corner in a `draw_frame` picture."""
    return 0, int(HEADER_CELLS * cell)


def _save_gif(images: list[Image.Image], out: Path, fps: float) -> None:
    """One palette for all frames (built from the first and last) keeps colours steady;
    Pillow's optimize then stores each frame with only the colours it uses: the same pixels in
    about a fifth of the bytes."""
    sample = Image.new("RGB", (images[0].width * 2, images[0].height))
    sample.paste(images[0], (0, 0))
    sample.paste(images[-1], (images[0].width, 0))
    palette = sample.quantize(colors=255, method=Image.Quantize.MEDIANCUT)
    paletted = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
    paletted[0].save(out, save_all=True, append_images=paletted[1:], loop=0,
                     duration=round(1000 / fps), optimize=True)


def render_game(record: dict, out: str | Path, step: int | None = None,
                viewer: int | None = None, fps: float = 8, cell: int = DEFAULT_CELL) -> int:
    """Write one step (`step` from 0, default the last) to a .png, or all steps to a .gif.

    Returns the number of frames written.
    """
    out = Path(out)
    suffix = out.suffix.lower()
    if suffix not in (".png", ".gif"):
        raise ValueError(f"{out}: the output must end in .png or .gif")
    game_frames = frames(record, viewer)
    last_step = game_frames[-1].step
    if suffix == ".gif":
        if step is not None:
            raise ValueError("--step picks the frame of a .png; a .gif shows every step")
        _save_gif([draw_frame(f, last_step, cell) for f in game_frames], out, fps)
        return len(game_frames)
    index = len(game_frames) - 1 if step is None else step
    if not 0 <= index < len(game_frames):
        raise ValueError(f"step {step} outside 0..{len(game_frames) - 1}")
    draw_frame(game_frames[index], last_step, cell).save(out)
    return 1
