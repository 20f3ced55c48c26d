"""`python -m rllib_pommer.play` played in real headless Chromium with key presses: the server's
game advances as pressed, the page draws the person's fog, a second page is refused, a reload
goes on with the game, closing the tab forfeits, and the saved replay passes `replay verify`."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import requests

from rllib_pommer.game.constants import Action, Item
from rllib_pommer.game.records import read_games
from rllib_pommer.viz.frames import frames
from rllib_pommer.viz.render import DEFAULT_CELL
from rllib_pommer.viz.tiles import COLOURS, PROBE, agent_colour, cell_layers

from ..viz.chromium import Browser, find_chromium

CHROMIUM = find_chromium()
pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="no Chromium on PATH (apt-get install chromium); the play test "
    "drives it headless over --remote-debugging-pipe")
SEAT = 1
KEYS = [("ArrowDown", Action.DOWN), ("ArrowLeft", Action.LEFT), ("x", Action.STOP),
        (" ", Action.BOMB), ("ArrowUp", Action.UP), ("Enter", Action.STOP),
        ("ArrowRight", Action.RIGHT)]
PLAY = "window.pommerPlay"


def start_play(out, *extra: str, team: str = "simple") -> tuple[subprocess.Popen, str]:
    process = subprocess.Popen(
        [sys.executable, "-m", "rllib_pommer.play", "--team", team, "--vs", "static",
         "--seat", str(SEAT), "--seed", "3", "--port", "0", "--turn-time", "wait",
         "--reconnect", "5",
         "--out", str(out), *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = process.stdout.readline().split()
    if first[:2] != ["play", "at"]:
        process.kill()
        raise AssertionError(f"play printed {first}, stderr: {process.stderr.read()}")
    return process, first[2]


def test_a_game_played_with_key_presses_in_chromium(tmp_path):
    out = tmp_path / "played.jsonl.gz"
    process, url = start_play(out)
    try:
        with Browser(CHROMIUM) as browser:
            page = browser.open(url)
            page.wait_for(f"{PLAY} && {PLAY}.ready && {PLAY}.seated()")
            drawn = [page.evaluate(f"{PLAY}.drawnTiles()")]
            for k, (key, _) in enumerate(KEYS):
                page.press(key)
                page.wait_for(f"{PLAY}.step() === {k + 1}")
                drawn.append(page.evaluate(f"{PLAY}.drawnTiles()"))
                state = requests.get(url + "state", timeout=5).json()
                assert state["step"] == k + 1
                assert [a[SEAT] for a in state["actions"]] == [a for _, a in KEYS[: k + 1]]
            assert page.evaluate(f"{PLAY}.error()") == ""
            probes = np.array(page.evaluate(
                f"Array.from({{length: 121}}, (_, k) => {PLAY}.pixel("
                f"Math.floor(((k % 11) + {PROBE[0]}) * {DEFAULT_CELL}), "
                f"Math.floor((Math.floor(k / 11) + {PROBE[1]}) * {DEFAULT_CELL})))"))
            probes = probes[:, :3].reshape(11, 11, 3)

            second = browser.open(url)
            second.wait_for("document.body && document.body.innerText.includes("
                            "'already being played in another page')")

            page.evaluate("window.reloaded = false; location.reload()")
            page.wait_for(f"window.reloaded === undefined && {PLAY} && {PLAY}.ready && "
                          f"{PLAY}.seated()")
            assert page.evaluate(f"{PLAY}.step()") == len(KEYS)
            page.close()
            stdout, stderr = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, stderr
    assert stdout.startswith(f"forfeit (the page was closed) after {len(KEYS)} steps")

    (record,) = read_games(out)
    assert [s["actions"][SEAT] for s in record["steps"]] == [a for _, a in KEYS]
    assert record["forfeit"] == {"seat": SEAT, "step": len(KEYS), "reason": "the page was closed"}
    seen = frames(record, SEAT)
    assert drawn == [cell_layers(f) for f in seen]  # the person's fog, at every step
    r0, c0 = seen[-1].agents[SEAT]["position"]
    assert np.abs(probes[r0, c0] - agent_colour(SEAT)).max() <= 3
    fogged = seen[-1].board == Item.FOG
    assert fogged.any() and (np.abs(probes[fogged] - COLOURS["fog"]).max(axis=-1) <= 3).all()
    verify = subprocess.run([sys.executable, "-m", "rllib_pommer.replay", "verify", str(out)],
                            capture_output=True, text=True, timeout=120)
    assert verify.returncode == 0, verify.stdout + verify.stderr
    assert verify.stdout.strip().splitlines()[-1] == \
        f"verified 1 games, {len(KEYS)} steps, 0 mismatches"



def test_radio_words_typed_as_digits_reach_the_game_and_the_teammates_show(tmp_path):
    """TeamRadio: two digits set the person's two words, which go out with every move; the page
    shows what the (speaking) teammate said last; a digit is no move."""
    out = tmp_path / "radio.jsonl.gz"
    process, url = start_play(out, "--variant", "radio", team="simple_words")
    try:
        with Browser(CHROMIUM) as browser:
            page = browser.open(url)
            page.wait_for(f"{PLAY} && {PLAY}.ready && {PLAY}.seated()")
            for key in "35":
                page.press(key)
            page.wait_for(f"{PLAY}.saying().join() === '3,5'")
            page.press("ArrowDown")
            page.wait_for(f"{PLAY}.step() === 1")
            page.press("7")  # word 1 again; word 2 stays
            page.wait_for(f"{PLAY}.saying().join() === '7,5'")
            page.press("ArrowUp")
            page.wait_for(f"{PLAY}.step() === 2")
            state = requests.get(url + "state", timeout=5).json()
            heard = page.evaluate(f"{PLAY}.heard()")
            assert page.evaluate(f"{PLAY}.error()") == ""
            page.close()
            process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    turns = [step[SEAT] for step in state["full_actions"]]
    assert turns == [[Action.DOWN, 3, 5], [Action.UP, 7, 5]]
    teammate = state["full_actions"][-1][(SEAT + 2) % 4]
    assert heard == f"{teammate[1]} {teammate[2]}"
    assert process.returncode == 0
