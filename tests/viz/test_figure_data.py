"""What the figures are drawn from: match names and results, heatmaps, the paper's tables; how
Figs. 3 and 5 draw it."""

from __future__ import annotations

import gzip
import json
import re

import numpy as np
import pytest

from rllib_pommer.game.rewards import REWARD_MODES
from rllib_pommer.viz.behaviour import Heatmaps, heatmaps_by_opponent, to_top_left
from rllib_pommer.viz.figures import (
    FIG5_MARKS,
    REWARD_AXES,
    plot_behaviour,
    plot_outcomes,
    plot_training,
)
from rllib_pommer.viz.matches import Match, load_outcomes, match_of
from rllib_pommer.viz.paper import FIG3_CLAIMS, PAPER_OPPONENTS, PAPER_TABLES, paper_table
from rllib_pommer.viz.report import fig3_readings
from rllib_pommer.viz.tables import milestones_table, phase_progress_table
from rllib_pommer.viz.training import TrainingCurve

from ..conftest import PAPER_TABLES as PAPER_TEX


def test_matches_are_named_by_sidecar_or_file_name(tmp_path):
    rows = [{"game": g, "seats_a": [0, 2], "result": r} for g, r in enumerate(["win", "tie"])]
    named = tmp_path / "ppo+jitter__vs__simple_action.jsonl"
    sidecar = tmp_path / "run7.jsonl"
    for path in (named, sidecar):
        path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    packed = tmp_path / "ppo__vs__static.jsonl.gz"  # gzipped, named the same way
    packed.write_bytes(gzip.compress(named.read_bytes()))
    assert match_of(packed) == Match("ppo", "vanilla", "static")
    (tmp_path / "run7.json").write_text("progress lines\n" + json.dumps(
        {"team": "ppo_action", "vs": "static", "filters": ["jitter"], "win": 0.5}))
    assert match_of(named) == Match("ppo", "jitter", "simple_action")
    assert match_of(sidecar) == Match("ppo", "jitter_action", "static")
    outcomes = load_outcomes([named, sidecar])
    assert outcomes[Match("ppo", "jitter", "simple_action")].rates() == (0.5, 0.0, 0.5)
    anonymous = tmp_path / "games.jsonl"
    anonymous.write_text("")
    with pytest.raises(ValueError, match="cannot tell which match"):
        match_of(anonymous)


def test_heatmaps_mirror_every_seat_to_the_top_left():
    starts = [(1, 1), (9, 1), (9, 9), (1, 9)]
    assert [to_top_left(p, s) for s, p in enumerate(starts)] == [(1, 1)] * 4

    def state(bombs):
        agents = [{"agent_id": i, "position": list(p), "is_alive": i != 3}
                  for i, p in enumerate([(1, 1), (9, 1), (9, 9), (1, 9)])]
        return {"agents": agents, "bombs": bombs}

    laid = {"position": [9, 2], "bomber_id": 1, "life": 9}
    older = {"position": [8, 1], "bomber_id": 1, "life": 8}
    enemy = {"position": [1, 2], "bomber_id": 0, "life": 9}
    record = {"initial_state": state([]), "steps": [{"state": state([laid, older, enemy])}],
              "seats_a": [1, 3], "vs": "static", "team": "ppo", "filters": ["jitter"]}
    older_replay = {key: value for key, value in record.items()
                    if key not in ("seats_a", "vs", "team", "filters")}
    older_replay.update(game=1, agent_mix="static ppo static ppo")
    by_match = heatmaps_by_opponent([record] * 3 + [older_replay], games_per_opponent=2)
    assert list(by_match) == [("ppo+jitter", "static"), ("ppo", "static")]  # named policies
    assert by_match["ppo", "static"].positions[1, 1] == 2  # seats {1, 3} from the game number
    maps = by_match["ppo+jitter", "static"]
    assert maps.games == 2
    assert maps.positions[1, 1] == 2 * 2  # agent 1 in both states of both games; agent 3 dead
    assert maps.bombs.sum() == 2 and maps.bombs[1, 2] == 2


def test_paper_numbers_are_the_tex_tables():
    tex = PAPER_TEX.read_text()
    our_name = {paper: ours for ours, paper in PAPER_OPPONENTS.items()}
    for team, label in (("imitation", "tab:results_imitation"), ("ppo", "tab:results_ppo")):
        end = tex.index(r"\label{" + label)
        start = tex.rindex(r"\begin{tabular}", 0, end)
        table = tex[start: tex.index(r"\end{tabular}", start)].replace(r"\_", "_")
        rows = {}
        for line in re.split(r"\\midrule|\\\\", table):
            cells = [c.strip() for c in line.split("&")]
            if len(cells) == 13 and cells[0] in our_name:
                values = [None if v == "-" else float("0.16" if v == "016" else v)
                          for v in cells[1:]]
                rows[our_name[cells[0]]] = [tuple(values[k: k + 3]) if values[k] is not None
                                            else None for k in range(0, 12, 3)]
        expected = {vs: list(cells.values()) for vs, cells in PAPER_TABLES[team][1].items()}
        assert rows == expected


def test_versions_of_our_teams_meet_the_paper_table_of_their_family():
    assert paper_table("imitation_v1") is paper_table("imitation") is PAPER_TABLES["imitation"]
    assert paper_table("imitation_v2") is PAPER_TABLES["imitation"]
    assert paper_table("ppo_v2") is PAPER_TABLES["ppo"]
    assert paper_table("ppo_league_v1") is PAPER_TABLES["ppo"]  # a version of a recipe of ours
    assert paper_table("ppo_team") is PAPER_TABLES["ppo"]  # ours, beside the agent it would beat
    assert paper_table("ppo_cautious") is None and paper_table("simple") is None


def test_fig3_draws_one_axis_per_reward_kind_and_says_what_its_mean_is_over(tmp_path):
    def curve(name, rewards):
        return TrainingCurve(name, np.arange(1, 5) * 100.0, np.linspace(-1, 0, 4),
                             ["a", "a", "b", "b"], rewards, np.full(4, 0.5), np.full(4, 0.25))

    fig = plot_training([curve("paper", ["shaped"] * 4), curve("no_shaping", ["raw"] * 4)],
                        tmp_path / "fig3.png")
    shaped, raw = fig.axes
    assert "shaped" in shaped.get_title() and "raw" in raw.get_title()
    assert [t.get_text() for t in shaped.get_legend().get_texts()] == ["paper"]
    assert [t.get_text() for t in raw.get_legend().get_texts()] == ["no_shaping"]
    assert "1,000-episode" in shaped.get_ylabel() and "100-episode means" in shaped.get_ylabel()
    # A run whose reward kind changes between phases is drawn on both axes.
    fig = plot_training([curve("mixed", ["shaped", "shaped", "raw", "raw"])],
                        tmp_path / "fig3.png")
    assert [len(ax.get_lines()) for ax in fig.axes] == [1 + 1, 1 + 1]  # segment + phase line
    with pytest.raises(ValueError, match="unknown reward kind"):
        plot_training([curve("x", ["dense"] * 4)], tmp_path / "fig3.png")
    assert set(REWARD_MODES) <= set(REWARD_AXES)  # every mode a run can train on has its axis


def test_fig5_names_its_policies_and_explains_its_marks(tmp_path):
    maps = {("ppo+jitter", "static"): Heatmaps(games=1), ("imitation", "simple"): Heatmaps(games=1)}
    maps["ppo+jitter", "static"].positions[1, 1] = 3
    fig = plot_behaviour(maps, tmp_path / "fig5.png")
    assert fig.get_suptitle() == "Fig. 5: positions and bomb placements of ppo+jitter, imitation"
    panels = [ax for ax in fig.axes if ax.get_title()]  # the colourbars have none
    grid = fig.axes[:2 * 2 * 2]  # the subplots come first, the colourbars after them
    assert [ax.get_ylabel() for ax in grid if ax.get_ylabel()] == ["ppo+jitter", "imitation"]
    # one row per policy, two columns per opponent; pairs not played stay blank
    assert [ax.get_title().split("\n")[0] for ax in panels] == [
        "vs StaticAgent: positions", "vs StaticAgent: bomb placements",
        "vs SimpleAgent: positions", "vs SimpleAgent: bomb placements"]
    assert fig.get_supxlabel() == FIG5_MARKS and "circle" in FIG5_MARKS


def test_training_outcomes_draw_kills_and_bombs_where_a_run_logs_them(tmp_path):
    episodes = np.arange(1, 5) * 100.0
    logged = TrainingCurve("league", episodes, np.zeros(4), ["a"] * 4, ["raw_kills"] * 4,
                           np.full(4, 0.5), np.full(4, 0.1), np.linspace(0.2, 0.8, 4),
                           np.linspace(12.0, 0.5, 4))
    silent = TrainingCurve("paper", episodes, np.zeros(4), ["a"] * 4, ["shaped"] * 4,
                           np.full(4, 0.5), np.full(4, 0.1))
    outcomes, kills, bombs = plot_outcomes([logged, silent], tmp_path / "o.png").axes
    assert [t.get_text() for t in kills.get_legend().get_texts()] == ["league"]
    assert "killed per game" in kills.get_ylabel()
    assert "bombs laid" in bombs.get_ylabel()
    np.testing.assert_allclose(bombs.get_lines()[0].get_ydata(), logged.bombs)
    kills_only = TrainingCurve("cautious", episodes, np.zeros(4), ["a"] * 4, ["shaped"] * 4,
                               np.full(4, 0.5), np.full(4, 0.1), np.full(4, 0.3))
    assert len(plot_outcomes([kills_only], tmp_path / "o.png").axes) == 2
    assert len(plot_outcomes([silent], tmp_path / "o.png").axes) == 1
    (axis,) = plot_training([logged], tmp_path / "fig3.png").axes
    assert "credited kill" in axis.get_title()


def test_milestones_compare_runs_at_equal_games_and_skip_what_none_reached():
    paper = TrainingCurve("paper", np.array([4_000.0, 9_000, 12_000, 21_000]), np.zeros(4),
                          ["warmup", "static", "static", "nobomb"], ["shaped"] * 4,
                          np.array([0.1, 0.2, 0.3, 0.4]), np.array([0.5, 0.4, 0.3, 0.2]))
    league = TrainingCurve("league", np.array([3_000.0, 6_000]), np.zeros(2), ["w", "l"],
                           ["raw_kills"] * 2, np.array([0.25, 0.75]), np.array([0.0, 0.05]),
                           np.array([0.5, 1.25]))
    header, rule, first, second = milestones_table([paper, league]).splitlines()
    assert header == "| run | 5,000 games | 10,000 games | 20,000 games |"
    assert first == ("| paper | 0.10 / 0.50 (warmup) | 0.20 / 0.40 (static) | "
                     "0.30 / 0.30 (static) |")
    assert second == "| league | 0.25 / 0.00, kills 0.50 (w) | — | — |"


def test_phase_progress_counts_games_from_each_phase_start_and_groups_phases():
    # `paper` meets SimpleAgent after 40,000 games, `no_curriculum` after 10,000: compared from
    # their first game against it, not at equal lifetimes.
    paper = TrainingCurve("paper", np.array([10_000.0, 40_000, 41_000, 42_500, 45_000]),
                          np.zeros(5), ["warmup", "nobomb", "simple", "simple", "simple"],
                          ["shaped"] * 5, np.array([0.2, 0.5, 0.55, 0.6, 0.7]),
                          np.array([0.7, 0.2, 0.3, 0.25, 0.2]))
    flat = TrainingCurve("no_curriculum", np.array([10_000.0, 11_000, 12_000]), np.zeros(3),
                         ["warmup", "simple", "simple"], ["shaped"] * 3,
                         np.array([0.2, 0.25, 0.3]), np.array([0.7, 0.65, 0.6]),
                         np.array([np.nan, 0.2, 0.3]), np.array([np.nan, 9.25, 8.5]))
    header, rule, *rows = phase_progress_table([paper, flat], (1_000, 2_500, 5_000)).splitlines()
    assert header == ("| phase | run | 1,000 games in | 2,500 games in | 5,000 games in "
                      "| at its end |")
    assert rows == [  # a phase with no row yet within m of its games has no figure there
        "| nobomb | paper | — | — | — | 0.50 / 0.20 (30,000 games) |",
        "| simple | no_curriculum | 0.25 / 0.65, kills 0.20, bombs 9.2 | — | — | "
        "0.30 / 0.60, kills 0.30, bombs 8.5 (2,000 games) |",
        "| simple | paper | 0.55 / 0.30 | 0.60 / 0.25 | 0.70 / 0.20 | 0.70 / 0.20 "
        "(5,000 games) |",
        "| warmup | no_curriculum | — | — | — | 0.20 / 0.70 (10,000 games) |",
        "| warmup | paper | — | — | — | 0.20 / 0.70 (10,000 games) |",
    ]


def test_each_fig3_reading_stands_beside_the_phase_rows_that_test_it():
    def curve(name, stages):
        n = len(stages)
        return TrainingCurve(name, np.arange(1, n + 1) * 1_000.0, np.zeros(n), stages,
                             ["raw"] * n, np.linspace(0.1, 0.5, n), np.linspace(0.5, 0.1, n))

    paper = curve("paper", ["value_warmup", "static", "simple_nobomb", "simple"])
    no_shaping = curve("no_shaping", ["value_warmup", "static", "simple_nobomb", "simple_nobomb"])
    league = curve("league", ["value_warmup", "league"])
    section = list(fig3_readings([paper, no_shaping, league]))
    shaping = next(k for k, text in enumerate(section) if "Without shaping" in text)
    rows = section[shaping + 1].splitlines()[2:]
    assert [row.split(" | ")[:2] for row in rows] == [  # its phases of its runs, nothing else
        ["| simple_nobomb", "no_shaping"], ["| simple_nobomb", "paper"],
        ["| static", "no_shaping"], ["| static", "paper"]]
    assert rows[0] == "| simple_nobomb | no_shaping | 0.37 / 0.23 | 0.50 / 0.10 (2,000 games) |"
    cautious = next(k for k, text in enumerate(section) if "cautious agent's reward" in text)
    assert section[cautious + 1] == "none of these runs reached these phases."
    assert all(claim.reading in "".join(section) for claim in FIG3_CLAIMS)


def test_fig3_names_phases_once_where_runs_share_them_and_never_over_each_other(tmp_path):
    """A dozen runs whose phases start together (the clone's runs at 0, the continued ones at
    the policy they continued) keep their phase names legible: a name several runs start at one
    place is written once, and no two names overlap."""
    def curve(name, start, stages):
        n = len(stages)
        return TrainingCurve(name, np.arange(1, n + 1) * 1_000.0, np.zeros(n), stages,
                             ["raw_kills"] * n, np.full(n, 0.5), np.full(n, 0.1), start=start,
                             origin="ppo" if start else None)

    clone = [curve(f"clone_{k}", 0, ["value_warmup", "static", "simple_nobomb", "simple"])
             for k in range(4)]
    continued = [curve(f"league_{k}", 83_562, ["value_warmup", f"league_{k}", "league_end"])
                 for k in range(8)]
    for plot in (plot_training, plot_outcomes):
        fig = plot(clone + continued, tmp_path / "fig.png")
        ax = fig.axes[0]
        names = list(ax.texts)
        shown = [text.get_text() for text in names]
        assert shown.count("value_warmup") == 2  # at 0 and at 83,563, each once, in grey
        assert shown.count("static") == 1 and shown.count("league_end") == 1
        assert {f"league_{k}" for k in range(8)} <= set(shown)
        fig.draw_without_rendering()  # where the names stand at the figure's own dpi
        boxes = [(text.get_text(), text.get_window_extent()) for text in names]
        assert not [(a, b) for i, (a, box) in enumerate(boxes) for b, other in boxes[i + 1:]
                    if box.overlaps(other)]
        assert "from `ppo` at 83,562" in (fig.axes[-1].get_xlabel())
