"""The run's Tune callbacks, on the driver: a progress line per iteration, the checkpoint at each
stage's end kept apart, and a stop at a checkpoint when `train --stop` asks.

Tune pickles them into its experiment state (`tuner.pkl`); a run never reads that back (it
resumes from its data, training.py), so they keep only per-process bookkeeping.
"""

from __future__ import annotations

import shutil
import signal
import time
from pathlib import Path

from ray import tune
from ray.tune.result import SHOULD_CHECKPOINT

from ..curriculum.names import LEARNER
from .packing import take_stop_request


def _duration(seconds: float) -> str:
    minutes, seconds = divmod(int(seconds), 60)
    return f"{minutes // 60}h{minutes % 60:02d}m" if minutes >= 60 else f"{minutes}m{seconds:02d}s"


def _eta(episodes_left: int, episodes_per_s: float) -> str:
    return _duration(max(episodes_left, 0) / episodes_per_s) if episodes_per_s > 0 else "?"


class Progress(tune.Callback):
    """One line per iteration: stage, episodes, win/loss/tie, env steps/s and the time left in the
    stage and in the run, both at the games/s seen since the first result. The run's figure is a
    floor early on, since a curriculum's later games may last longer (the paper campaign's are
    measured in docs/measurements.md), so the line says whose pace it assumes. Under prioritized
    matchmaking it names the league member the learner will meet most. An iteration
    whose learner skipped updates for non-finite gradients (learner.py) says how many."""

    def __init__(self):
        self._first: tuple[float, int] | None = None  # (time, episodes) of the first result seen

    def on_trial_result(self, iteration, trials, trial, result, **info):
        stage = result.get("curriculum", {})
        runners = result.get("env_runners", {})
        episodes, total = stage.get("episodes", 0), stage.get("total_episodes", 0)
        now = time.monotonic()
        if self._first is None:  # measure from here: start-up and restore are not training
            self._first = (now, episodes)
        elapsed = now - self._first[0]
        rate = (episodes - self._first[1]) / elapsed if elapsed > 0 else 0.0
        stage_end = stage.get("stage_end_episodes", total)
        steps_per_s = runners.get("num_env_steps_sampled", 0) / max(result["time_this_iter_s"],
                                                                       1e-9)
        print(f"[{stage.get('stage', 0) + 1}:{stage.get('stage_name', '?')}] "
              f"iter {result['training_iteration']}  episodes {episodes}/{total}  "
              f"W/L/T {runners.get('learner_win', 0):.2f}/{runners.get('learner_loss', 0):.2f}/"
              f"{runners.get('learner_tie', 0):.2f}  return {runners.get('learner_return', 0):+.2f}"
              f"{_kills(runners)}"
              f"  {steps_per_s:.0f} env steps/s  ETA stage {_eta(stage_end - episodes, rate)}, "
              f"run {_eta(total - episodes, rate)} at this stage's pace{_hardest(result)}"
              f"{_skipped(result)}", flush=True)


def _hardest(result: dict) -> str:
    """Under prioritized matchmaking, the member that gets the largest share of the coming
    games, with the learner's win-rate estimate against it (curriculum/matchmaking.py)."""
    shares = result.get("matchmaking")
    if not shares:
        return ""
    name, entry = max(shares.items(), key=lambda item: item[1]["share"])
    return f"  most played next: {name} {entry['share']:.2f} (won {entry['win_rate']:.2f})"


def _kills(runners: dict) -> str:
    """Per game: enemies the learner's team killed, and each team's suicides, where logged."""
    if "learner_kills" not in runners:
        return ""
    return (f"  kills {runners['learner_kills']:.2f} (suicides ours "
            f"{runners.get('learner_suicides', 0):.2f}, theirs "
            f"{runners.get('learner_opponent_suicides', 0):.2f})")


def _skipped(result: dict) -> str:
    skipped = result.get("learners", {}).get(LEARNER, {}).get("nonfinite_updates_skipped", 0)
    return f"  ({skipped:.0f} updates skipped: non-finite gradients)" if skipped else ""


class StopOnRequest(tune.Callback):
    """Stops the run, with every iteration it finished in a checkpoint, when `train --stop`
    asks (`packing.stop_run`): the first result after the request is checkpointed (Tune's
    `should_checkpoint`), and once that checkpoint is saved the driver interrupts itself as
    Ctrl-C would, before another iteration ends. Tune stays in charge of the trial's state, so
    the run resumes as after Ctrl-C (a trial stopped by Tune's own criteria would count as
    finished and never resume)."""

    def __init__(self):
        self._stopping: set[str] = set()

    def on_trial_result(self, iteration, trials, trial, result, **info):
        if take_stop_request(Path(trial.path).parent):  # <run>/<trial>
            result[SHOULD_CHECKPOINT] = True
            self._stopping.add(trial.trial_id)

    def on_checkpoint(self, iteration, trials, trial, checkpoint, **info):
        if trial.trial_id in self._stopping:
            signal.raise_signal(signal.SIGINT)  # Tune's handler ends the run after this step


class StageCheckpoints(tune.Callback):
    """Copies the checkpoint taken at a stage's end to `<run>/stages/<number>-<stage name>`, out of
    reach of Tune's rotation (it keeps the latest three): the policy after each phase of the
    curriculum, to evaluate or to put in a league (policy kind rllib_checkpoint)."""

    def __init__(self):
        self._ended: dict[str, str] = {}

    def on_trial_result(self, iteration, trials, trial, result, **info):
        ended = result.get("curriculum", {}).get("ended_stage")
        if ended:
            self._ended[trial.trial_id] = ended

    def on_checkpoint(self, iteration, trials, trial, checkpoint, **info):
        ended = self._ended.pop(trial.trial_id, None)
        if ended:
            run_dir = Path(checkpoint.path).parents[1]  # <run>/<trial>/checkpoint_*
            shutil.copytree(checkpoint.path, run_dir / "stages" / ended, dirs_exist_ok=True)
