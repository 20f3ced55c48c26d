"""The progress line: stage, episodes, outcomes, and ETAs from the rate since the first result."""

from __future__ import annotations

from rllib_pommer.launch import tune_callbacks


def _result(iteration, episodes):
    return {"training_iteration": iteration, "time_this_iter_s": 10.0,
            "curriculum": {"stage": 0, "stage_name": "value_warmup", "episodes": episodes,
                           "stage_end_episodes": 10_000, "total_episodes": 100_000},
            "env_runners": {"num_env_steps_sampled": 4000, "learner_win": 0.25,
                            "learner_loss": 0.5, "learner_tie": 0.25, "learner_return": -0.5}}


def test_progress_line_and_eta_after_a_resume(monkeypatch, capsys):
    clock = iter([1000.0, 1100.0])  # start-up and restore before the first result do not count
    monkeypatch.setattr(tune_callbacks.time, "monotonic", lambda: next(clock))
    progress = tune_callbacks.Progress()
    progress.on_trial_result(1, [], None, _result(51, 8_000))
    progress.on_trial_result(2, [], None, _result(52, 8_200))  # 2 episodes/s
    first, second = capsys.readouterr().out.splitlines()
    assert "ETA stage ?" in first
    assert second.startswith("[1:value_warmup] iter 52  episodes 8200/100000  W/L/T 0.25/0.50/0.25")
    assert "400 env steps/s" in second
    # 1,800 episodes left in the stage at 2/s = 15 min; 91,800 in the run = 12 h 45 min.
    assert second.endswith("ETA stage 15m00s, run 12h45m at this stage's pace")


def test_progress_line_tells_of_skipped_updates(capsys):
    result = _result(53, 1_200)
    result["learners"] = {"learner": {"nonfinite_updates_skipped": 3}}
    tune_callbacks.Progress().on_trial_result(1, [], None, result)
    assert capsys.readouterr().out.rstrip().endswith(
        "at this stage's pace  (3 updates skipped: non-finite gradients)")
