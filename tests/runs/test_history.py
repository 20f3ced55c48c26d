"""A run's history read, summarised and computed into what the training figures draw: curves,
restores and clocks, summaries, stage figures."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from rllib_pommer.runs.history import (
    Origin,
    exported_training,
    league_curves,
    read_rows,
    rolling_mean,
    run_origin,
    run_training,
    stage_figures,
    training_curve,
    write_summary,
)
from rllib_pommer.viz.figures import plot_league, plot_outcomes, plot_training
from rllib_pommer.viz.tables import training_table

REPO = Path(__file__).resolve().parents[2]


def _trial_with_progress(folder, progress_csv: str):
    """A trial folder in `folder` whose progress.csv is `progress_csv`."""
    trial = folder / "PPO_pommer_00000"
    trial.mkdir()
    (trial / "progress.csv").write_text(progress_csv)
    return trial


def test_rolling_mean_weights_rows_by_their_episodes():
    means, counts = np.array([0.0, 0.0, 1.0]), np.array([500, 500, 500])
    np.testing.assert_allclose(rolling_mean(means, counts, window=1000), [0, 0, 0.5])
    np.testing.assert_allclose(rolling_mean(np.array([2.0]), np.array([0])), [np.nan])


def test_training_curve_from_progress_csv_restarts_at_each_phase(tmp_path):
    trial = _trial_with_progress(
        tmp_path,
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
    trial = _trial_with_progress(
        tmp_path,
        "env_runners/episode_return_mean,env_runners/num_episodes_lifetime,curriculum_stage,"
        "env_runners/learner_win,env_runners/learner_loss\n"
        "0.0,500,static,0.2,0.6\n0.0,1000,static,,\n0.0,1500,static,0.6,0.2\n"
        "0.0,2000,simple,,\n")
    curve = training_curve(trial)
    np.testing.assert_allclose(curve.wins, [0.2, 0.2, 0.4, np.nan])
    np.testing.assert_allclose(curve.losses, [0.6, 0.6, 0.4, np.nan])
    fig = plot_outcomes([curve], tmp_path / "outcomes.png")
    (ax,) = fig.axes
    assert ax.get_ylim()[0] == 0 and max(ax.get_yticks()) == 1  # the top: room for names
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [curve.name, "win", "loss"]


def test_kills_and_bombs_curves_are_the_same_means_where_logged(tmp_path):
    trial = _trial_with_progress(
        tmp_path,
        "env_runners/episode_return_mean,env_runners/num_episodes_lifetime,curriculum_stage,"
        "env_runners/learner_kills,env_runners/learner_bombs\n"
        "0.0,500,nobomb,1.0,15.0\n0.0,1000,nobomb,0.0,1.0\n0.0,1500,nobomb,,\n")
    curve = training_curve(trial)
    np.testing.assert_allclose(curve.kills, [1.0, 0.5, 0.5])
    np.testing.assert_allclose(curve.bombs, [15.0, 8.0, 8.0])


def test_training_curve_from_nested_result_json_without_stages(tmp_path):
    rows = [{"env_runners": {"episode_return_mean": r, "num_episodes": 10}} for r in (1, 3)]
    (tmp_path / "result.json").write_text("".join(json.dumps(r) + "\n" for r in rows))
    curve = training_curve(tmp_path)
    np.testing.assert_allclose(curve.returns, [1.0, 2.0])
    assert curve.stages == ["", ""]
    (tmp_path / "result.json").write_text(json.dumps({"loss": 1.0}) + "\n")
    with pytest.raises(ValueError, match="needs a return column"):
        training_curve(tmp_path)


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


def test_a_summary_keeps_a_leagues_per_opponent_outcomes_and_its_gate(tmp_path):
    rows = [{"training_iteration": i, "env_runners": {
                "num_episodes_lifetime": 10 * i, "learner_win": 0.5,
                "learner_win_vs_static": 0.25 * i, "learner_kills_vs_simple": 1.5,
                "learner_return_vs_simple": 0.1},
             "league": {"gate_games": 40 * i, "gate_win_rate": 0.5, "snapshots": 0}}
            for i in (1, 2)]
    trial = tmp_path / "PPO_pommerman_team_00000"
    trial.mkdir()
    (trial / "result.json").write_text("".join(json.dumps(r) + "\n" for r in rows))
    header, *lines = (write_summary(trial, tmp_path / "out") / "progress.csv").read_text(
        ).splitlines()
    columns = header.split(",")
    assert {"env_runners/learner_win_vs_static", "env_runners/learner_kills_vs_simple",
            "league/gate_games", "league/gate_win_rate", "league/snapshots"} <= set(columns)
    assert "env_runners/learner_return_vs_simple" not in columns
    kept = dict(zip(columns, lines[1].split(","), strict=True))
    assert kept["env_runners/learner_win_vs_static"] == "0.5" and kept["league/gate_games"] == "80"


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


def test_league_curves_weight_each_members_rows_by_its_games_and_carry_shares(tmp_path):
    """Per member: outcome rates over its last games (a row weighted by its games against the
    member; a row without any weighs nothing), shares where matchmaking logged them; drawn
    one panel a member."""
    columns = ("env_runners/episode_return_mean,env_runners/num_episodes_lifetime,"
               "env_runners/learner_win_vs_ppo,env_runners/learner_loss_vs_ppo,"
               "env_runners/learner_tie_vs_ppo,env_runners/league_games_vs_ppo,"
               "env_runners/learner_win_vs_static,env_runners/learner_loss_vs_static,"
               "env_runners/learner_tie_vs_static,env_runners/league_games_vs_static,"
               "matchmaking/ppo/share,matchmaking/static/share\n")
    trial = _trial_with_progress(tmp_path, columns +
                                 "0.0,10,0.0,0.0,1.0,3,1.0,0.0,0.0,1,0.5,0.5\n"
                                 "0.0,20,1.0,0.0,0.0,1,,,,,0.8,0.2\n"
                                 "0.0,30,,,,,0.0,1.0,0.0,3,0.75,0.25\n")
    league = league_curves(trial, window=4)
    np.testing.assert_array_equal(league.episodes, [10, 20, 30])
    assert list(league.members) == ["ppo", "static"]
    ppo, static = league.members["ppo"], league.members["static"]
    np.testing.assert_allclose(ppo.tie, [1.0, 0.75, 0.75])  # 3 ties, then 1 win: 3 of 4
    np.testing.assert_allclose(ppo.win, [0.0, 0.25, 0.25])
    np.testing.assert_allclose(static.loss, [0.0, 0.0, 0.75])  # the last 4 games: 3 losses
    np.testing.assert_allclose(ppo.share, [0.5, 0.8, 0.75])
    (tmp_path / "plain").mkdir()
    plain = _trial_with_progress(tmp_path / "plain", "env_runners/episode_return_mean,"
                                 "env_runners/num_episodes_lifetime\n0.0,10\n")
    assert league_curves(plain) is None  # no league played
    figure = plot_league(league, tmp_path / "league.png")
    assert (tmp_path / "league.png").stat().st_size > 10_000
    assert [ax.get_title() for ax in figure.axes[:2]] == ["ppo", "static"]


def _games(policy: str) -> int:
    """The games the run that exported `policy` trained it, from the policy folder's history."""
    _, training = exported_training(REPO / "policies" / policy)
    return sum(stage.episodes for stage in training.stages)


def _continued_run(folder, start_weights):
    """A run folder whose curriculum starts pi from `start_weights`, with one trial of two
    iterations (10 and 20 games), as the trainer notes and logs them."""
    curriculum = folder / "continued.toml"
    folder.mkdir()
    curriculum.write_text(f'name = "continued"\npi_weights = "{start_weights}"\n'
                          '[[stage]]\nname = "simple"\nopponent = "simple"\nepisodes = 20\n')
    (folder / "curriculum.json").write_text(json.dumps({"curriculum": str(curriculum),
                                                        "name": "continued"}))
    trial = folder / "PPO_pommerman_team_00000"
    trial.mkdir()
    rows = [{"training_iteration": i, "curriculum": {"iteration_stage_name": "simple"},
             "env_runners": {"num_episodes_lifetime": 10 * i, "episode_return_mean": 0.5}}
            for i in (1, 2)]
    (trial / "result.json").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return folder


@pytest.mark.parametrize(("policy", "before"), [
    ("ppo", ("ppo",)),  # paper_dual_clip, the first leagues
    ("ppo_league_v1", ("ppo", "ppo_league_v1")),  # the second leagues: the lineage adds up
    ("ppo_league", ("ppo", "ppo_league_v1", "ppo_league")),  # a run from the second league's agent
    ("imitation", ()),  # a run from the clone starts at 0
])
def test_a_continued_run_starts_at_the_games_of_the_policy_it_continued(tmp_path, policy,
                                                                         before):
    """The run's curriculum names the weights pi started from; the shipped policy holding them
    and the games of its lineage, counted from the imitation clone, are where its curve starts.
    The report's summary of the run notes that origin, so a redraw from it starts there too."""
    run = _continued_run(tmp_path / "run", REPO / "policies" / policy / "pi.pt")
    games = sum(_games(name) for name in before)
    assert run_origin(run / "PPO_pommerman_team_00000") == Origin(policy, games)
    training = run_training([run], summaries=tmp_path / "summaries")
    (curve,) = training.curves
    assert (curve.origin, curve.start) == (policy, games)
    np.testing.assert_array_equal(curve.episodes, [10, 20])  # the run's own count stays
    (again,) = run_training([tmp_path / "summaries" / "run"]).curves
    assert (again.origin, again.start) == (policy, games)
    (line, *_) = plot_training([curve], tmp_path / "fig3.png").axes[0].get_lines()
    np.testing.assert_array_equal(line.get_xdata(), [games + 10, games + 20])


def test_a_run_started_from_weights_no_policy_ships_starts_at_zero(tmp_path):
    weights = tmp_path / "elsewhere" / "pi.pt"
    weights.parent.mkdir()
    shutil.copy(REPO / "policies" / "ppo" / "pi.pt", weights)  # equal weights, not a policy's file
    run = _continued_run(tmp_path / "run", weights)
    assert run_origin(run / "PPO_pommerman_team_00000") == Origin()
    assert training_curve(run / "PPO_pommerman_team_00000").start == 0


def test_a_resumed_run_reads_its_legs_as_one(tmp_path):
    """Each --resume starts a new Tune trial from the newest checkpoint: the run's history is
    its legs in the order Tune's folder names say they started (not their ids), the later leg's
    rows replacing the iterations it ran again, on one clock; the report finds one run."""
    from rllib_pommer.runs.history import find_trials, legs, read_trial

    def leg(name, iterations, clock):
        trial = tmp_path / "run" / name
        trial.mkdir(parents=True)
        (trial / "result.json").write_text("".join(json.dumps(
            {"training_iteration": k, "time_total_s": clock + 5.0 * (k - iterations[0] + 1),
             "time_this_iter_s": 5.0,
             "env_runners": {"num_episodes_lifetime": 10 * k, "episode_return_mean": float(k)}})
            + "\n" for k in iterations))
        return trial

    first = leg("PPO_pommerman_team_ffff0_00000_0_2026-12-06_20-06-42", [1, 2, 3, 4], 0.0)
    second = leg("PPO_pommerman_team_00001_00000_0_2026-12-07_09-00-00", [4, 5], 0.0)
    assert legs(second) == [first, second] and legs(first) == [first]
    assert find_trials(tmp_path) == [second]
    rows = read_trial(second).rows
    assert [r["training_iteration"] for r in rows] == [1, 2, 3, 4, 5]
    assert [r["time_total_s"] for r in rows] == [5.0, 10.0, 15.0, 20.0, 25.0]
    assert [r["training_iteration"] for r in read_trial(second, whole_run=False).rows] == [4, 5]
    assert training_curve(second).episodes[-1] == 50
