"""The HTML viewer in real headless Chromium: it steps, draws each step's state, fogs, plays,
and fetches nothing from the network."""

from __future__ import annotations

import numpy as np
import pytest

from rllib_pommer.game.constants import Item
from rllib_pommer.viz.frames import frames, game_states, load_game
from rllib_pommer.viz.render import DEFAULT_CELL
from rllib_pommer.viz.tiles import BASE_TILE, COLOURS, PROBE, agent_colour, cell_layers
from rllib_pommer.viz.viewer import write_viewer

from .chromium import Browser, find_chromium

CHROMIUM = find_chromium()
pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="no Chromium on PATH (apt-get install chromium); the viewer test "
    "drives it headless over --remote-debugging-pipe")
GROUND_CODE = {name: code for code, name in BASE_TILE.items() if code in
               (Item.PASSAGE, Item.RIGID, Item.WOOD, Item.FLAMES, Item.FOG, Item.EXTRA_BOMB,
                Item.INCR_RANGE, Item.KICK)}


def board_from_tiles(drawn: list[list[str]]) -> np.ndarray:
    """The board codes that the drawn tile stacks depict (agent over bomb over ground)."""
    codes = []
    for stack in drawn:
        agents = [name for name in stack if name.startswith("agent")]
        if agents:
            codes.append(Item.AGENT0 + int(agents[0][5:]))
        elif any(name.startswith("bomb") for name in stack):
            codes.append(Item.BOMB)
        else:
            codes.append(GROUND_CODE[stack[0]])
    return np.array(codes).reshape(11, 11)


def click(page, element_id: str) -> None:
    page.evaluate(f"document.getElementById({element_id!r}).click()")


def pixel_at(page, r: int, c: int) -> np.ndarray:
    x, y = int((c + PROBE[0]) * DEFAULT_CELL), int((r + PROBE[1]) * DEFAULT_CELL)
    return np.array(page.evaluate(f"window.pommerViewer.pixel({x}, {y})")[:3])


def test_viewer_steps_draws_the_state_and_fogs(game_record, tmp_path):
    html = tmp_path / "game.html"
    write_viewer(game_record, html)
    states = game_states(game_record)
    with Browser(CHROMIUM) as browser:
        page = browser.open(html.as_uri())
        page.wait_for("window.pommerViewer && window.pommerViewer.ready")
        viewer = "window.pommerViewer"
        first_picture = page.evaluate("document.getElementById('board').toDataURL()")

        for _ in range(3):
            click(page, "next")
        assert page.evaluate(f"{viewer}.frame()") == 3
        assert page.evaluate("document.getElementById('board').dataset.frame") == "3"
        assert page.evaluate("document.getElementById('board').toDataURL()") != first_picture
        drawn = page.evaluate(f"{viewer}.drawnTiles()")
        np.testing.assert_array_equal(board_from_tiles(drawn), states[3]["board"])

        page.evaluate("const s = document.getElementById('slider'); s.value = 6;"
                      "s.dispatchEvent(new Event('input'))")
        assert page.evaluate(f"{viewer}.frame()") == 6
        board = np.asarray(states[6]["board"])
        np.testing.assert_array_equal(board_from_tiles(page.evaluate(f"{viewer}.drawnTiles()")),
                                      board)
        rigid = tuple(np.argwhere(board == Item.RIGID)[0])
        assert np.abs(pixel_at(page, *rigid) - COLOURS["rigid"]).max() <= 3
        agent = next(a for a in states[6]["agents"] if a["is_alive"])
        colour = agent_colour(agent["agent_id"])
        assert np.abs(pixel_at(page, *agent["position"]) - colour).max() <= 3

        click(page, "view-2")
        assert page.evaluate(f"{viewer}.view()") == "2"
        assert page.evaluate(f"{viewer}.drawnTiles()") == cell_layers(frames(game_record, 2)[6])
        r0, c0 = states[6]["agents"][2]["position"]
        far = next((r, c) for r in range(11) for c in range(11)
                   if max(abs(r - r0), abs(c - c0)) > 4)
        assert np.abs(pixel_at(page, *far) - COLOURS["fog"]).max() <= 3

        click(page, "play")
        page.wait_for(f"{viewer}.frame() > 7", timeout=5)
        click(page, "play")
        paused_at = page.evaluate(f"{viewer}.frame()")
        assert page.evaluate(f"new Promise(r => setTimeout(() => r({viewer}.frame()), 400))") \
            == paused_at

        fetched = browser.requested_urls()
    assert fetched and all(url.startswith(("file:", "data:")) for url in fetched), fetched


def test_radio_viewer_shows_each_agents_last_words(radio_games, tmp_path):
    record = load_game(radio_games, 0)
    states = game_states(record)
    html = tmp_path / "radio.html"
    write_viewer(record, html)
    with Browser(CHROMIUM) as browser:
        page = browser.open(html.as_uri())
        page.wait_for("window.pommerViewer && window.pommerViewer.ready")
        heads = "[...document.querySelectorAll('#agents-head th')].map(th => th.textContent)"
        assert page.evaluate(heads)[-1] == "words"
        for _ in range(4):
            click(page, "next")
        cells = page.evaluate("[...document.querySelectorAll('#agents tr')]"
                              ".map(tr => tr.lastElementChild.textContent)")
    assert cells == [f"{w1} {w2}" for w1, w2 in states[4]["radio_from_agent"]]
