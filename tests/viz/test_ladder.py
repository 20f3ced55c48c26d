"""The ladder drawn: its table says each policy's place, and the report takes a ladder's folder
beside the other inputs (the plot as a readable PNG, the table below it)."""

from __future__ import annotations

import numpy as np
from PIL import Image

from rllib_pommer.arena.ladder import LADDER_FILE, Ladder, rate, write_ladder
from rllib_pommer.report import main
from rllib_pommer.viz.ladder import ladder_table

from ..arena.test_ladder import games


def ladder_folder(tmp_path):
    """A ladder folder as the job leaves it, from records whose outcome is certain: simple beats
    static and random every game, static and random tie every game."""
    ladder = Ladder(("random", "simple", "static"), 20, bootstrap=50)
    played = {("random", "simple"): games("random", "simple", ["loss"] * 20),
              ("random", "static"): games("random", "static", ["tie"] * 20),
              ("simple", "static"): games("simple", "static", ["win"] * 20)}
    folder = tmp_path / "ladder"
    folder.mkdir()
    write_ladder(folder / LADDER_FILE, ladder, rate(ladder, played), played)
    return folder, ladder, played


def test_the_table_ranks_policies_and_words_a_certain_outcome(tmp_path):
    _, ladder, played = ladder_folder(tmp_path)
    table = ladder_table({"games_per_pair": 20, "seed": 0, "bootstrap": 50},
                         rate(ladder, played)).splitlines()
    assert table[0].startswith("Round robin of 3 policies, 20 games a pair (seats balanced)")
    assert table[4].startswith("| 1 | `simple` | +") and "| won every game | 40 | 40 / 0 / 0 |" \
        in table[4]
    rows = {row.split("`")[1]: row for row in table[5:]}
    assert set(rows) == {"random", "static"} and all("| 40 | 0 / 20 / 20 |" in r
                                                     for r in rows.values())


def test_the_report_draws_a_ladder_folder(tmp_path, capsys):
    folder, _, _ = ladder_folder(tmp_path)
    out = tmp_path / "report"
    assert main([str(folder), "--out", str(out)]) == 0
    report = (out / "report.md").read_text()
    assert "## The ladder" in report and f"From `{folder}`:" in report
    assert "![the ladder](ladder.png)" in report and "| 1 | `simple` |" in report
    assert "_No records among the inputs._" in report
    with Image.open(out / "ladder.png") as image:
        pixels = np.asarray(image.convert("L"))
    assert pixels.shape[0] > 150 and pixels.std() > 10
    assert main(["--card", str(tmp_path), str(folder)]) == 2  # a card takes records only
    assert "--card takes arena record files only" in capsys.readouterr().err
