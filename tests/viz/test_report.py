"""The report command on tiny inputs: tables beside the paper's, the figures as readable PNGs."""

from __future__ import annotations

import json
import re

import numpy as np
from PIL import Image

from rllib_pommer.arena.records import GameRecord, write_records
from rllib_pommer.game.records import write_games
from rllib_pommer.report import main

from .conftest import play_recorded


def write_rows(path, results):
    """Arena records with the given results, written as `evaluate --records` writes them."""
    write_records(path, [GameRecord(g, 0, [0, 2] if g % 2 == 0 else [1, 3], r, 100, [False] * 4,
                                    [False] * 4, [1] * 4) for g, r in enumerate(results)])


def assert_picture(path):
    with Image.open(path) as image:
        pixels = np.asarray(image.convert("L"))
    assert pixels.shape[0] > 200 and pixels.std() > 10, path


def test_report_from_records_trials_and_replays(tmp_path, replay_file, capsys):
    records = tmp_path / "records"
    records.mkdir()
    write_rows(records / "ppo__vs__static.jsonl", ["win", "loss", "tie", "tie"])
    write_rows(records / "ppo+jitter+action__vs__static.csv", ["win", "win", "win", "tie"])
    write_rows(records / "ppo_action__vs__static.jsonl", ["win", "tie", "tie", "tie"])
    write_rows(records / "simple__vs__simple.jsonl", ["win", "loss"])
    trial = tmp_path / "runs" / "PPO_pommer_00000"
    trial.mkdir(parents=True)
    (trial / "progress.csv").write_text(
        "env_runners/episode_return_mean,env_runners/num_episodes_lifetime,curriculum_stage\n"
        + "".join(f"{0.01 * k - 0.5},{40 * k},{'static' if k < 20 else 'simple'}\n"
                  for k in range(1, 40)))
    replays = tmp_path / "static_replays.jsonl"
    write_games(replays, [play_recorded(s, 60, seats_a=[s % 2, s % 2 + 2], vs="static")
                          for s in range(3)])
    out = tmp_path / "report"

    assert main([*map(str, sorted(records.iterdir())), str(tmp_path / "runs"), str(replays),
                 str(replay_file), "--out", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    report = (out / "report.md").read_text()
    assert "### Table 3: PPO team — ours: `ppo`" in report
    assert ("| StaticAgent (`static`) | 0.250 / 0.250 / 0.500 (n=4)<br>[0.046, 0.699] / "
            "[0.046, 0.699] / [0.150, 0.850]<br>paper 0.179 / 0.138 / 0.681 "
            "| —<br>paper 0.614 / 0.253 / 0.132 | 0.250 / 0.000 / 0.750 (n=4)<br>[0.046, 0.699] "
            "/ [0.000, 0.490] / [0.301, 0.954]") in report  # Wilson's, clamped to [0, 1]
    assert "0.750 / 0.000 / 0.250 (n=4)<br>[0.301, 0.954]" in report
    assert "[0.046, 0.699]<br>paper 0.904 / 0.023 / 0.073 |" in report
    assert ("| SimpleAgent (`simple`) | 0.500 / 0.500 / 0.000 (n=2)<br>[0.095, 0.905] / "
            "[0.095, 0.905] / [0.000, 0.658] | — | — | — |") in report
    assert "blue circle marks that start cell" in report  # Fig. 5's marks explained
    for picture in ("fig3_training.png", "fig4_filters_ppo.png", "fig5_behaviour.png",
                    "game.png"):
        assert f"]({picture})" in report
        assert_picture(out / picture)
    assert "fig4_filters_simple.png" not in report  # no filtered variant to compare with
    assert (out / "game.html").stat().st_size > 10_000
    # Fig. 3's data, a trial folder the report reads again: the same figure from the summary.
    summary = out / "runs" / "runs" / "progress.csv"
    assert summary.read_text().startswith("env_runners/episode_return_mean,")
    again = tmp_path / "again"
    assert main([str(out / "runs"), "--out", str(again)]) == 0
    assert_picture(again / "fig3_training.png")


def test_report_says_which_inputs_it_could_not_read(tmp_path, capsys):
    stray = tmp_path / "notes.jsonl"
    stray.write_text(json.dumps({"hello": 1}) + "\n")
    assert main([str(stray), "--out", str(tmp_path / "out")]) == 2
    assert "neither arena records" in capsys.readouterr().err
    write_rows(tmp_path / "games.jsonl", ["win"])
    assert main([str(tmp_path / "games.jsonl"), "--out", str(tmp_path / "out")]) == 2
    assert "cannot tell which match" in capsys.readouterr().err


def test_report_reads_evaluate_records_alone(tmp_path, capsys):
    """`evaluate --records` rows name their match: no sidecar, any file name, .jsonl, .jsonl.gz
    or .csv."""
    from rllib_pommer.evaluate import main as evaluate

    games = {"games.jsonl": ["--team", "static", "--vs", "simple"],
             "more.csv": ["--team", "static_action", "--vs", "simple", "--filters", "jitter"],
             "packed.jsonl.gz": ["--team", "static", "--vs", "simple", "--filters", "action"]}
    for name, match in games.items():
        assert evaluate([*match, "--games", "2", "--workers", "1",
                         "--records", str(tmp_path / name)]) == 0
    out = tmp_path / "report"
    assert main([str(tmp_path / name) for name in games] + ["--out", str(out)]) == 0
    report = (out / "report.md").read_text()
    assert "### Team `static` (not in the paper)" in report
    row = next(line for line in report.splitlines() if line.startswith("| SimpleAgent"))
    vanilla, jitter, action, jitter_action = row.split(" | ")[1:5]
    assert "(n=2)<br>[" in vanilla and "(n=2)<br>[" in jitter_action  # rates, then intervals
    assert "(n=2)<br>[" in action and jitter == "—"
    for low, high in re.findall(r"\[(\d\.\d+), (\d\.\d+)\]", row):
        assert 0.0 <= float(low) <= float(high) <= 1.0
