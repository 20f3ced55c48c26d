"""What the figures are drawn from: training curves, match names and results, heatmaps."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from rllib_pommer.viz.behaviour import Heatmaps, heatmaps_by_opponent, to_top_left
from rllib_pommer.viz.figures import FIG5_MARKS, plot_behaviour, plot_outcomes, plot_training
from rllib_pommer.viz.matches import Match, load_outcomes, match_of
from rllib_pommer.viz.paper import PAPER_OPPONENTS, PAPER_TABLES, paper_table
from rllib_pommer.viz.tables import training_table
from rllib_pommer.viz.training import (
    TrainingCurve,
    read_rows,
    rolling_mean,
    stage_figures,
    training_curve,
    write_summary,
)

from ..conftest import PAPER_TABLES as PAPER_TEX


def test_rolling_mean_weights_rows_by_their_episodes():
    means, counts = np.array([0.0, 0.0, 1.0]), np.array([500, 500, 500])
    np.testing.assert_allclose(rolling_mean(means, counts, window=1000), [0, 0, 0.5])
    np.testing.assert_allclose(rolling_mean(np.array([2.0]), np.array([0])), [np.nan])


def test_training_curve_from_progress_csv_restarts_at_each_phase(tmp_path):
    trial = tmp_path / "PPO_pommer_00000"
    trial.mkdir()
    (trial / "progress.csv").write_text(
        "training_iteration,env_runners/episode_return_mean,env_runners/num_episodes_lifetime,"
        "curriculum_stage\n"
        "1,,0,static\n"  # no episode finished yet: skipped
        "2,-1.0,600,static\n3,0.0,1200,static\n4,1.0,1700,simple\n5,1.0,2200,simple\n")
    curve = training_curve(trial)
    np.testing.assert_array_equal(curve.episodes, [600, 1200, 1700, 2200])
    np.testing.assert_allclose(curve.returns, [-1.0, -0.4, 1.0, 1.0])
    assert curve.stages == ["static", "static", "simple", "simple"]


def test_win_and_loss_curves_are_the_same_means_and_skip_rows_without_them(tmp_path):
    """Weighted by episodes, restarted per phase; a row that logged no rate weighs nothing, a
    phase without any is NaN; the figure draws both per run on one 0..1 axis."""
    trial = tmp_path / "PPO_pommer_00000"
    trial.mkdir()
    (trial / "progress.csv").write_text(
        "env_runners/episode_return_mean,env_runners/num_episodes_lifetime,curriculum_stage,"
        "env_runners/learner_win,env_runners/learner_loss\n"
        "0.0,500,static,0.2,0.6\n0.0,1000,static,,\n0.0,1500,static,0.6,0.2\n"
        "0.0,2000,simple,,\n")
    curve = training_curve(trial)
    np.testing.assert_allclose(curve.wins, [0.2, 0.2, 0.4, np.nan])
    np.testing.assert_allclose(curve.losses, [0.6, 0.6, 0.4, np.nan])
    fig = plot_outcomes([curve], tmp_path / "outcomes.png")
    (ax,) = fig.axes
    assert ax.get_ylim() == (0, 1)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        f"{curve.name}: win", f"{curve.name}: loss"]


def test_training_curve_from_nested_result_json_without_stages(tmp_path):
    rows = [{"env_runners": {"episode_return_mean": r, "num_episodes": 10}} for r in (1, 3)]
    (tmp_path / "result.json").write_text("".join(json.dumps(r) + "\n" for r in rows))
    curve = training_curve(tmp_path)
    np.testing.assert_allclose(curve.returns, [1.0, 2.0])
    assert curve.stages == ["", ""]
    (tmp_path / "result.json").write_text(json.dumps({"loss": 1.0}) + "\n")
    with pytest.raises(ValueError, match="needs a return column"):
        training_curve(tmp_path)


def test_matches_are_named_by_sidecar_or_file_name(tmp_path):
    rows = [{"game": g, "seats_a": [0, 2], "result": r} for g, r in enumerate(["win", "tie"])]
    named = tmp_path / "ppo+jitter__vs__simple_action.jsonl"
    sidecar = tmp_path / "run7.jsonl"
    for path in (named, sidecar):
        path.write_text("".join(json.dumps(r) + "\n" for r in rows))
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


def test_a_restored_runs_rows_replace_the_discarded_ones(tmp_path):
    def row(iteration, lifetime, ret):
        return {"training_iteration": iteration, "curriculum": {"stage_name": "warmup"},
                "env_runners": {"num_episodes_lifetime": lifetime, "episode_return_mean": ret}}

    # Checkpoint after iteration 2; iterations 3-4 ran, were lost, and were run again.
    rows = [row(1, 10, 0.0), row(2, 20, 0.0), row(3, 30, 9.0), row(4, 40, 9.0),
            row(3, 30, 1.0), row(4, 40, 1.0)]
    (tmp_path / "result.json").write_text("".join(json.dumps(r) + "\n" for r in rows))
    # A CSV scrambled by the resume is not read when result.json is there.
    (tmp_path / "progress.csv").write_text("training_iteration,x\n1,2\n3,garbage,more\n")
    curve = training_curve(tmp_path, window=20)
    np.testing.assert_array_equal(curve.episodes, [10, 20, 30, 40])
    np.testing.assert_allclose(curve.returns, [0.0, 0.0, 0.5, 1.0])


def test_a_clock_restarted_by_a_restore_is_carried_on(tmp_path):
    """Tune restarts time_total_s at 0 when it restores a checkpoint registered without its
    result; the iterations go on, so the rows count on from the time before the drop."""
    def row(iteration, seconds):
        return {"training_iteration": iteration, "time_total_s": seconds,
                "curriculum": {"iteration_stage_name": "simple"},
                "env_runners": {"num_episodes_lifetime": 10 * iteration,
                                "episode_return_mean": 0.0}}

    rows = [row(1, 5.0), row(2, 10.0), row(3, 4.0), row(4, 9.0), row(5, 3.0)]
    (tmp_path / "result.json").write_text("".join(json.dumps(r) + "\n" for r in rows))
    clock = [float(r["time_total_s"]) for r in read_rows(tmp_path)]
    assert clock == [5.0, 10.0, 14.0, 19.0, 22.0]
    (figures,) = stage_figures(tmp_path)
    assert figures.seconds == 22.0


def test_a_packed_clock_adds_each_iterations_own_seconds(tmp_path):
    """A pack keeps result.json's lines from its checkpoint on beside history.csv: their clock
    restarted long before (raw 20 s at iteration 3, where the history had carried it to 120 s),
    so only each iteration's own seconds may be added to the history's clock."""
    with open(tmp_path / "history.csv", "w") as f:
        f.write("training_iteration,time_total_s,env_runners/num_episodes_lifetime,"
                "env_runners/module_episode_returns_mean/learner\n"
                "1,100.0,10,0.0\n2,110.0,20,0.0\n3,120.0,30,0.0\n")
    results = [{"training_iteration": k, "time_total_s": raw, "time_this_iter_s": 10.0,
                "env_runners": {"num_episodes_lifetime": 10 * k, "episode_return_mean": 0.0}}
               for k, raw in ((3, 20.0), (4, 30.0))]
    (tmp_path / "result.json").write_text("".join(json.dumps(r) + "\n" for r in results))
    clock = [float(r["time_total_s"]) for r in read_rows(tmp_path)]
    assert clock == [100.0, 110.0, 120.0, 130.0]


def test_lines_cut_short_are_skipped_with_a_warning_naming_them(tmp_path):
    def line(ret):
        return json.dumps({"env_runners": {"episode_return_mean": ret, "num_episodes": 10}})

    # A run killed mid-write and resumed leaves a torn line 2; a live run is mid-way on line 4.
    (tmp_path / "result.json").write_text(
        line(1) + "\n" + line(9)[:25] + line(3) + "\n" + line(5) + "\n" + line(7)[:30])
    with pytest.warns(UserWarning, match=r"result.json: skipped line\(s\) \[2, 4\]"):
        curve = training_curve(tmp_path)
    np.testing.assert_allclose(curve.returns, [1.0, 3.0])


def test_a_summary_keeps_the_curve_and_the_training_figures_only(tmp_path):
    def row(iteration, ret, win):
        return {"training_iteration": iteration, "curriculum": {"stage_name": "warmup"},
                "env_runners": {"num_episodes_lifetime": 10 * iteration,
                                "module_episode_returns_mean": {"learner": ret},
                                "learner_win": win, "timers": {"sample": 1.5}},
                "config": {"lr": 1e-4}}

    rows = [row(1, -1.0, 0.0), row(2, 0.5, 0.25), row(1, 0.0, 0.5), row(2, 1.0, 1.0)]
    trial = tmp_path / "PPO_pommerman_team_00000"
    trial.mkdir()
    (trial / "result.json").write_text("".join(json.dumps(r) + "\n" for r in rows))
    summary = write_summary(trial, tmp_path / "summary" / "quick")
    header, *lines = (summary / "progress.csv").read_text().splitlines()
    assert header.split(",") == [
        "training_iteration", "env_runners/learner_win",
        "env_runners/module_episode_returns_mean/learner", "env_runners/num_episodes_lifetime",
        "curriculum/stage_name"]
    assert len(lines) == 2  # the restored run's rows replaced the discarded ones
    again, first = training_curve(summary, window=20), training_curve(trial, window=20)
    np.testing.assert_allclose(again.returns, first.returns)
    np.testing.assert_array_equal(again.episodes, first.episodes)
    assert again.stages == first.stages == ["warmup", "warmup"]
    assert again.name == "quick"


def test_an_iteration_counts_in_the_stage_it_played_also_across_versions(tmp_path):
    def row(iteration, **curriculum):
        return {"training_iteration": iteration, "curriculum": curriculum,
                "env_runners": {"num_episodes_lifetime": 10 * iteration,
                                "episode_return_mean": 0.0}}

    # An older version logged only the stage in force after the iteration; a newer one resumed
    # the run after iteration 2 and logs the stage each iteration played in.
    rows = [row(1, stage_name="warmup"), row(2, stage_name="warmup"),
            row(3, stage_name="static", iteration_stage_name="warmup"),
            row(4, stage_name="static", iteration_stage_name="static")]
    (tmp_path / "result.json").write_text("".join(json.dumps(r) + "\n" for r in rows))
    assert training_curve(tmp_path).stages == ["warmup", "warmup", "warmup", "static"]
    summary = write_summary(tmp_path, tmp_path / "summary")
    assert training_curve(summary).stages == ["warmup", "warmup", "warmup", "static"]


def test_stage_figures_add_up_each_phase_and_weight_rates_by_episodes(tmp_path):
    def row(iteration, stage, episodes, win, variance):
        return {"training_iteration": iteration, "time_total_s": 60.0 * iteration,
                "curriculum": {"iteration_stage_name": stage},
                "env_runners": {"num_episodes_lifetime": episodes,
                                "num_env_steps_sampled_lifetime": 1000 * iteration,
                                "episode_return_mean": 0.0, "learner_win": win,
                                "learner_loss": 1 - win, "learner_tie": 0.0},
                "learners": {"learner": {"vf_explained_var": variance}}}

    rows = [row(1, "warmup", 10, 0.0, 0.1), row(2, "warmup", 40, 1.0, 0.3),
            row(3, "static", 50, 0.5, 0.5)]
    trial = tmp_path / "PPO_x"
    trial.mkdir()
    (trial / "result.json").write_text("".join(json.dumps(r) + "\n" for r in rows))
    warmup, static = stage_figures(trial)
    assert (warmup.stage, warmup.iterations, warmup.episodes, warmup.env_steps, warmup.seconds) \
        == ("warmup", 2, 40, 2000, 120.0)
    assert warmup.win == pytest.approx((10 * 0.0 + 30 * 1.0) / 40)
    assert warmup.explained_variance == pytest.approx((0.2, 0.2))
    assert (static.episodes, static.env_steps, static.win) == (10, 1000, 0.5)
    assert np.isnan(static.override_share)  # not logged
    table = training_table([warmup, static])
    assert "| tmp_path | warmup | 2 | 40 | 2,000 | 0.03 | 17 | 0.750 / 0.250 / 0.000 | — |" \
        .replace("tmp_path", tmp_path.name) in table


def test_versions_of_our_teams_meet_the_paper_table_of_their_family():
    assert paper_table("imitation_v1") is paper_table("imitation") is PAPER_TABLES["imitation"]
    assert paper_table("imitation_v2") is PAPER_TABLES["imitation"]
    assert paper_table("ppo_v2") is PAPER_TABLES["ppo"]
    assert paper_table("ppo_team") is PAPER_TABLES["ppo"]  # ours, beside the agent it would beat
    assert paper_table("ppo_cautious") is None and paper_table("simple") is None


def test_each_rows_reward_kind_comes_from_the_log_or_else_the_trials_params(tmp_path):
    def row(iteration, **curriculum):
        return {"training_iteration": iteration, "curriculum": curriculum,
                "env_runners": {"num_episodes_lifetime": 10 * iteration,
                                "episode_return_mean": 0.0}}

    old, new = tmp_path / "PPO_old", tmp_path / "PPO_new"
    for trial, rows in ((old, [row(1), row(2)]),
                        (new, [row(1, iteration_reward="shaped"), row(2, iteration_reward="raw")])):
        trial.mkdir()
        (trial / "result.json").write_text("".join(json.dumps(r) + "\n" for r in rows))
    assert training_curve(old).rewards == ["", ""]  # not logged, no params.json: unknown
    (old / "params.json").write_text(json.dumps({"env_config": {"reward": "raw"}}))
    (new / "params.json").write_text(json.dumps({"env_config": {"reward": "shaped"}}))
    assert training_curve(old).rewards == ["raw", "raw"]
    assert training_curve(new).rewards == ["shaped", "raw"]  # the log wins
    assert training_curve(write_summary(old, tmp_path / "summary")).rewards == ["raw", "raw"]


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


def test_fig5_names_its_policies_and_explains_its_marks(tmp_path):
    maps = {("ppo+jitter", "static"): Heatmaps(games=1), ("imitation", "simple"): Heatmaps(games=1)}
    maps["ppo+jitter", "static"].positions[1, 1] = 3
    fig = plot_behaviour(maps, tmp_path / "fig5.png")
    assert fig.get_suptitle() == "Fig. 5: positions and bomb placements of ppo+jitter, imitation"
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert titles[0].startswith("ppo+jitter vs StaticAgent: positions")
    assert fig.get_supxlabel() == FIG5_MARKS and "circle" in FIG5_MARKS
