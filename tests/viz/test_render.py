"""Pillow pictures: known cells show their colours, fog hides what the agent cannot see."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from PIL import Image

from rllib_pommer.game.constants import Item
from rllib_pommer.replay import main as replay_main
from rllib_pommer.viz.frames import frames, game_states, load_game
from rllib_pommer.viz.render import DEFAULT_CELL, agent_line, board_origin, render_game
from rllib_pommer.viz.tiles import COLOURS, PROBE, agent_colour, faded
from rllib_pommer.viz.viewer import viewer_data


def probe(image: Image.Image, r: int, c: int, cell: int = DEFAULT_CELL) -> np.ndarray:
    x0, y0 = board_origin(cell)
    x, y = x0 + int((c + PROBE[0]) * cell), y0 + int((r + PROBE[1]) * cell)
    return np.array(image.convert("RGB").getpixel((x, y)))


def assert_colour(image, r, c, expected, tolerance=3):
    got = probe(image, r, c)
    assert np.abs(got - np.array(expected)).max() <= tolerance, f"{(r, c)}: {got} != {expected}"


def first_cell(board: np.ndarray, code: int) -> tuple[int, int]:
    return tuple(int(v) for v in np.argwhere(board == code)[0])


def test_png_shows_walls_agents_bombs_and_the_dead_in_their_colours(game_record, tmp_path):
    states = game_states(game_record)
    step = next(t for t, s in enumerate(states) if s["bombs"] and all(
        np.asarray(s["board"])[tuple(b["position"])] == Item.BOMB for b in s["bombs"]))
    board = np.asarray(states[step]["board"])
    out = tmp_path / "frame.png"
    assert render_game(game_record, out, step=step) == 1
    image = Image.open(out)
    assert len(image.convert("RGB").getcolors(1 << 16)) > 20  # not blank
    assert_colour(image, *first_cell(board, Item.RIGID), COLOURS["rigid"])
    assert_colour(image, *first_cell(board, Item.WOOD), COLOURS["wood"])
    assert_colour(image, *first_cell(board, Item.PASSAGE), COLOURS["passage"])
    assert_colour(image, *first_cell(board, Item.BOMB), COLOURS["bomb"])
    for agent in states[step]["agents"]:
        if agent["is_alive"]:
            assert_colour(image, *agent["position"], agent_colour(agent["agent_id"]))

    render_game(game_record, out)  # the last step: someone died
    last = states[-1]
    dead = next(a for a in last["agents"] if not a["is_alive"])
    if np.asarray(last["board"])[tuple(dead["position"])] != Item.FLAMES:
        assert_colour(Image.open(out), *dead["position"], faded(agent_colour(dead["agent_id"])))


def test_fog_hides_exactly_the_cells_outside_the_agents_window(game_record, tmp_path):
    step = 5
    out = tmp_path / "fog.png"
    render_game(game_record, out, step=step, viewer=1)
    image = Image.open(out)
    state = game_states(game_record)[step]
    board = np.asarray(state["board"])
    r0, c0 = state["agents"][1]["position"]
    for r in range(11):
        for c in range(11):
            if max(abs(r - r0), abs(c - c0)) > 4:
                assert_colour(image, r, c, COLOURS["fog"])
            elif board[r, c] == Item.RIGID:
                assert_colour(image, r, c, COLOURS["rigid"])


def test_views_from_recorded_observations_match_views_derived_from_states(replay_file):
    record = load_game(replay_file, 1)
    assert record["has_observations"]
    stripped = copy.deepcopy(record)
    stripped["has_observations"] = False
    for viewer in range(4):
        for recorded, derived in zip(frames(record, viewer), frames(stripped, viewer),
                                     strict=True):
            np.testing.assert_array_equal(recorded.board, derived.board)
            np.testing.assert_array_equal(recorded.bomb_life, derived.bomb_life)


def test_gif_has_one_frame_per_state(game_record, tmp_path):
    out = tmp_path / "game.gif"
    count = render_game(game_record, out, fps=20)
    with Image.open(out) as gif:
        assert gif.n_frames == count == len(game_record["steps"]) + 1


def test_replay_cli_renders_and_writes_the_viewer(replay_file, tmp_path, capsys):
    png, html = tmp_path / "a.png", tmp_path / "a.html"
    assert replay_main(["render", str(replay_file), "--game", "1", "--out", str(png),
                        "--step", "3", "--fog", "2"]) == 0
    assert Image.open(png).size[0] == 11 * DEFAULT_CELL
    assert replay_main(["html", str(replay_file), "--out", str(html)]) == 0
    page = html.read_text()
    assert "http://" not in page and "https://" not in page
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize("args, message", [
    (["--out", "x.jpg"], "must end in .png or .gif"),
    (["--out", "x.png", "--step", "9999"], "outside"),
    (["--out", "x.gif", "--step", "2"], "a .gif shows every step"),
    (["--out", "x.png", "--fog", "4"], "not one of 0..3"),
    (["--out", "x.png", "--game", "5"], "no game 5; the file holds 2"),
])
def test_replay_cli_explains_bad_requests(replay_file, tmp_path, capsys, args, message):
    args = [a.replace("x.", str(tmp_path / "x.")) for a in args]
    assert replay_main(["render", str(replay_file), *args]) == 2
    assert message in capsys.readouterr().err


def test_radio_pictures_show_each_agents_last_words(radio_games, tmp_path):
    """The header of a TeamRadio frame says the words each agent sent in that step; the board
    is drawn exactly as without them."""
    record = load_game(radio_games, 0)
    states = game_states(record)
    step = next(t for t, s in enumerate(states) if any(map(any, s["radio_from_agent"])))
    words = states[step]["radio_from_agent"]
    assert frames(record)[step].words == words == frames(record, 1)[step].words
    agent = states[step]["agents"][0]
    assert agent_line(agent, words[0]).endswith(f"says {words[0][0]} {words[0][1]}")
    assert "says" not in agent_line(agent)
    silent = copy.deepcopy(record)
    for state in game_states(silent):
        del state["radio_from_agent"]
    with_words, without = tmp_path / "words.png", tmp_path / "silent.png"
    render_game(record, with_words, step=step)
    render_game(silent, without, step=step)
    header = board_origin()[1]
    spoken, plain = np.asarray(Image.open(with_words)), np.asarray(Image.open(without))
    assert not np.array_equal(spoken[:header], plain[:header])
    np.testing.assert_array_equal(spoken[header:], plain[header:])


def test_the_viewer_gets_the_words_of_radio_games_only(radio_games, game_record):
    record = load_game(radio_games, 2)
    data = viewer_data(record)
    assert data["words"] == [s["radio_from_agent"] for s in game_states(record)]
    assert viewer_data(game_record)["words"] is None
