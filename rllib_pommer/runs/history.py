"""A run's history: the format of its Tune trial folders, read, summarised and computed into
what the training figures draw (`viz/training.py`: this module computes, viz/ draws).

A trial directory holds `result.json` (one JSON result per line, flattened with "/" as Tune
does; read first: Tune's CSV appends rows whose set of keys changed under the old header, which
scrambles the columns) or `progress.csv`, one row per training iteration, and, in a run packed
to be carried to another machine (`launch.packing.pack_run`), `history.csv`: the summary rows of the
iterations before the pack, read before the others. A run holds one Tune trial per start, its
legs (`legs`: each `--resume` starts a new trial from the newest checkpoint, launch/training.py),
in the order of the start time Tune puts in the trial's name; a trial's history is its run's
rows up to and including its own leg (`read_trial`), so a resumed run reads as one. A resumed
run repeats the iterations after its checkpoint: the rows of the restored run replace the ones
it discarded. Its clock, `time_total_s`, restarts at 0 in a new leg (and did in older runs
restored from a checkpoint registered without its result), so the rows are given one clock
that adds up each iteration's own seconds (`with_continuous_clock`). A line that is not JSON
(a write cut short: a live run mid-line, or a run killed mid-write and then
resumed) is skipped with a warning naming the file and line. Columns used:

- the mean episode return: the first present of `RETURN_COLUMNS` (required);
- the episode count: `env_runners/num_episodes_lifetime` (cumulative) or, failing that,
  `env_runners/num_episodes` (per iteration) (one of them required);
- the curriculum phase: `curriculum/iteration_stage_name` (what `python -m rllib_pommer.train`
  logs: the stage the iteration played in), `curriculum/stage_name` (older runs: the stage in
  force after it, so the iteration that ends a stage counts in the next), `curriculum_stage` or
  `curriculum_kind` (optional; without it the run is one phase);
- the kind of return, `shaped` or `raw`: `curriculum/iteration_reward` (logged since the report
  drew one axis per kind); in older rows, the env's reward in the trial's `params.json` (the
  first stage's, right for every shipped curriculum, whose stages share one reward); else unknown.

Rows without a return (empty or NaN: no episode finished yet) are skipped. A row's return is what
RLlib logs: the mean over the last `RLLIB_WINDOW` episodes (its default smoothing window), not
over the iteration's own episodes. The curve weights each row by the episodes its iteration
finished and averages the last `WINDOW` episodes' worth, restarted at each phase change so a
phase's curve never mixes opponents: a mean of 100-episode means spanning about 1,100 episodes.

A run continued from a shipped policy starts where that policy's training ended: its `Origin`
(`run_origin`) is the policy its curriculum's `pi_weights` names and the games of that policy's
lineage, counted from the imitation clone (`lineage`). A curve keeps the run's own episode
counts and carries the origin beside them (`TrainingCurve.start`), which Fig. 3 adds; a run from
the clone, or from weights no shipped policy holds, starts at 0.

`write_summary` keeps a trial's curve columns and `SUMMARY_COLUMNS` in a small progress.csv (a
few hundred bytes per iteration instead of a result.json's ~25 KB), itself a trial directory this
module reads: the report writes one per run beside Fig. 3, with the run's origin in
`ORIGIN_FILE`, so the figure and the figures quoted from a run can be redrawn after the run
directory is gone.
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
import warnings
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..agents.registry import policy_names, resolve_policy
from ..curriculum.curriculum import run_curriculum
from ..viz.training import (
    MEMBER_WINDOW,
    OUTCOME_KEYS,
    WINDOW,
    LeagueCurves,
    MemberCurves,
    StageFigures,
    Training,
    TrainingCurve,
    phases,
)

RETURN_COLUMNS = ("env_runners/module_episode_returns_mean/learner",
                  "env_runners/episode_return_mean", "episode_reward_mean")
LIFETIME_COLUMNS = ("env_runners/num_episodes_lifetime", "num_episodes_lifetime")
PER_ITERATION_COLUMNS = ("env_runners/num_episodes", "episodes_this_iter")
STAGE_COLUMNS = ("curriculum/iteration_stage_name", "curriculum/stage_name", "curriculum_stage",
                 "curriculum_kind")
REWARD_COLUMN = "curriculum/iteration_reward"
HISTORY_FILE = "history.csv"
# An exported policy's folder (`runs/export.export_policy`): where it came from, and the
# summary of its run's rows up to the exported checkpoint, which its model card is drawn from.
POLICY_SOURCE_FILE = "source.json"
POLICY_HISTORY_DIR = "history"
SOURCE_KEYS = ("policy", "run", "checkpoint", "iteration", "curriculum", "exported_at_commit",
               "run_commits")
TRIAL_FILES = ("result.json", "progress.csv", HISTORY_FILE)
ORIGIN_FILE = "origin.json"  # in a trial folder: its run's `Origin`, read before the curriculum
# Kept by `write_summary` beside the columns the curve is drawn from (what our trainer logs).
SUMMARY_COLUMNS = (
    "training_iteration", "time_total_s", "env_runners/num_env_steps_sampled_lifetime",
    "curriculum/pi_frozen", "env_runners/learner_win", "env_runners/learner_loss",
    "env_runners/learner_tie", "env_runners/learner_override_share",
    "env_runners/learner_kills", "env_runners/learner_suicides",
    "env_runners/learner_opponent_suicides", "env_runners/learner_bombs",
    "env_runners/episode_len_mean", "learners/learner/vf_explained_var",
    "learners/learner/pi_logit_spread", "learners/learner/nonfinite_updates_skipped",
    "learners/learner/pi_log_ratio_max", "learners/learner/pi_log_ratio_min",
    "learners/learner/pi_rare_rows", "learners/learner/pi_rare_log_ratio_max",
    "learners/learner/pi_rare_log_ratio_min", "learners/learner/pi_dual_clipped_rows",
    "time_this_iter_s")
# Kept too, whatever follows the prefix: a league's per-opponent outcomes and its gate's book.
SUMMARY_PREFIXES = ("env_runners/learner_win_vs_", "env_runners/learner_loss_vs_",
                    "env_runners/learner_tie_vs_", "env_runners/learner_kills_vs_", "league/",
                    "env_runners/league_games_vs_", "matchmaking/")


def run_name(trial: Path) -> str:
    """A trial's label: its run directory's name (`runs/quick` -> "quick") when Tune named the
    trial itself (PPO_<env>_<id>...), else the trial directory's own name."""
    return trial.parent.name if trial.name.startswith("PPO_") else trial.name


def is_trial(path: Path) -> bool:
    return path.is_dir() and any((path / name).is_file() for name in TRIAL_FILES)


# The start time Tune puts at the end of a trial folder's name (PPO_<env>_<id>_<n>_<time>).
TRIAL_STARTED = re.compile(r"_(\d{4}-\d\d-\d\d_\d\d-\d\d-\d\d)$")


def legs(trial: Path) -> list[Path]:
    """The trials of `trial`'s run up to and including it, in the order they started: for a
    folder Tune named (PPO_...), its siblings so named that hold results, ordered by the start
    time in their names; any other trial folder (a report's summary) stands alone."""
    trial = Path(trial)
    if not trial.name.startswith("PPO_"):
        return [trial]
    run = [p for p in trial.parent.glob("PPO_*") if is_trial(p) or p == trial]

    def started(path: Path) -> tuple[str, str]:
        found = TRIAL_STARTED.search(path.name)
        return (found.group(1) if found else "", path.name)
    run.sort(key=started)
    return run[:run.index(trial) + 1]


def find_trials(path: Path) -> list[Path]:
    """`path` if it is a trial directory, else the trial directories below it, one per run: the
    newest leg of each, whose history holds the others (`legs`)."""
    if is_trial(path):
        return [path]
    found = sorted({p.parent for name in TRIAL_FILES for p in path.rglob(name)})
    return [trial for trial in found if not any(
        trial in legs(other)[:-1] for other in found if other.parent == trial.parent)]


def _flatten(result: dict, prefix: str = "") -> dict:
    flat = {}
    for key, value in result.items():
        if isinstance(value, dict):
            flat.update(_flatten(value, f"{prefix}{key}/"))
        else:
            flat[prefix + key] = value
    return flat


def _json_rows(path: Path) -> list[dict]:
    rows, unreadable = [], []
    with open(path) as f:
        for number, line in enumerate(f, start=1):
            if not line.strip():
                continue
            try:
                rows.append(_flatten(json.loads(line)))
            except json.JSONDecodeError:
                unreadable.append(number)
    if unreadable:
        warnings.warn(f"{path}: skipped line(s) {unreadable}, not JSON (a write cut short)",
                      stacklevel=3)
    return rows


def _csv_rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _leg_rows(trial: Path) -> list[dict]:
    """One trial folder's own rows, as written, each with the reward mode it was paid in."""
    rows = _csv_rows(trial / HISTORY_FILE) if (trial / HISTORY_FILE).is_file() else []
    if (trial / "result.json").is_file():
        rows += _json_rows(trial / "result.json")
    elif (trial / "progress.csv").is_file():
        rows += _csv_rows(trial / "progress.csv")
    started_with = _started_reward(trial)
    return [row if row.get(REWARD_COLUMN) or not started_with
            else {**row, REWARD_COLUMN: started_with} for row in rows]


def read_rows(trial: Path, whole_run: bool = True) -> list[dict]:
    """The rows of `trial` in training order, restores resolved and on one clock: with
    `whole_run`, those of every leg of its run up to it (`legs`), else its own alone."""
    rows = [row for leg in (legs(trial) if whole_run else [trial]) for row in _leg_rows(leg)]
    return with_continuous_clock(without_discarded(rows))


def _started_reward(trial: Path) -> str:
    """The env's reward mode the trial started with, from Tune's params.json ("" if unknown)."""
    try:
        params = json.loads((trial / "params.json").read_text())
    except (OSError, ValueError):
        return ""
    reward = params.get("env_config", {}).get("reward") if isinstance(params, dict) else None
    return reward if isinstance(reward, str) else ""


@dataclass
class Trial:
    """A trial directory and its rows, read once (a long run's result.json is large)."""

    path: Path
    rows: list[dict]

    @property
    def name(self) -> str:
        return run_name(self.path)


def read_trial(trial: Trial | Path, whole_run: bool = True) -> Trial:
    """A trial folder and its rows (`read_rows`): by default its run's up to it."""
    return trial if isinstance(trial, Trial) else Trial(Path(trial),
                                                        read_rows(Path(trial), whole_run))


def write_summary(trial: Trial | Path, out: Path, name: str = "progress.csv") -> Path:
    """`out`/`name`: the trial's rows (restores resolved), only the columns the curve is drawn
    from and those of `SUMMARY_COLUMNS` and `SUMMARY_PREFIXES` it has; written whole or not at
    all (it may replace the file the rows were read from)."""
    rows = read_trial(trial).rows
    curve = [_column(rows, names) for names in (RETURN_COLUMNS, LIFETIME_COLUMNS,
                                                PER_ITERATION_COLUMNS)]
    prefixed = sorted({c for row in rows for c in row if c.startswith(SUMMARY_PREFIXES)})
    columns = list(dict.fromkeys(c for c in [*SUMMARY_COLUMNS, *curve, *STAGE_COLUMNS,
                                             REWARD_COLUMN, *prefixed]
                                 if c and any(c in row for row in rows)))
    out.mkdir(parents=True, exist_ok=True)
    partial = out / f".{name}.tmp"
    with open(partial, "w", newline="") as f:
        writer = csv.DictWriter(f, columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    os.replace(partial, out / name)
    return out


def without_discarded(rows: list[dict]) -> list[dict]:
    """The rows in training order after restores: an iteration number that does not grow starts
    a restored run, whose rows replace those from that iteration on."""
    kept: list[dict] = []
    last = -math.inf
    for row in rows:
        iteration = number(row.get("training_iteration"))
        if iteration <= last:
            kept = [k for k in kept if not number(k.get("training_iteration")) >= iteration]
        last = iteration if math.isfinite(iteration) else last
        kept.append(row)
    return kept


def with_continuous_clock(rows: list[dict]) -> list[dict]:
    """The rows (in training order, restores resolved) with one clock (module docstring): the
    first row's `time_total_s`, then each row adds its own seconds, `time_this_iter_s` where
    logged, else the growth of `time_total_s` since the row before, or all of it where it ran back
    (a restore that restarted it at 0). A row's total alone cannot say: a restarted clock may
    have run for hours before a pack put its rows after the ones it had restarted under."""
    carried, clock, last = [], math.nan, math.nan
    for row in rows:
        total = number(row.get("time_total_s"))
        if not math.isfinite(total):
            carried.append(row)
            continue
        own = number(row.get("time_this_iter_s"))
        if not math.isfinite(own):
            own = total - last if total >= last else total
        clock = total if math.isnan(clock) else clock + own
        last = total
        carried.append(row if clock == total else {**row, "time_total_s": clock})
    return carried


def number(value) -> float:
    """A cell as a float; NaN where it is empty or not a number."""
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _column(rows: list[dict], names: tuple[str, ...]) -> str | None:
    return next((n for n in names if any(n in row for row in rows)), None)


def rolling_mean(means: np.ndarray, counts: np.ndarray, window: int = WINDOW) -> np.ndarray:
    """Per row, the mean return of the last `window` episodes up to it (NaN before any)."""
    per_episode = np.repeat(means, counts)
    total = np.concatenate([[0.0], np.cumsum(per_episode)])
    ends = np.cumsum(counts)
    starts = np.maximum(ends - window, 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (total[ends] - total[starts]) / (ends - starts)


def _values(rows: list[dict], column: str | None) -> np.ndarray:
    return np.array([number(row.get(column)) for row in rows]) if column else \
        np.full(len(rows), np.nan)


def _increments(rows: list[dict], column: str) -> np.ndarray:
    """Per row, the growth of a lifetime counter since the row before."""
    return np.diff(np.maximum.accumulate(np.nan_to_num(_values(rows, column))), prepend=0)


def _episode_counts(trial: Trial) -> np.ndarray:
    """Episodes finished in each row's iteration."""
    rows = trial.rows
    lifetime_col = _column(rows, LIFETIME_COLUMNS)
    if lifetime_col:
        return _increments(rows, lifetime_col)
    per_iter_col = _column(rows, PER_ITERATION_COLUMNS)
    if per_iter_col is None:
        raise ValueError(f"{trial.path}: needs an episode count ({LIFETIME_COLUMNS[0]} or "
                         f"{PER_ITERATION_COLUMNS[0]})")
    return np.nan_to_num(_values(rows, per_iter_col))


def training_curve(trial: Trial | Path, window: int = WINDOW,
                   origin: Origin | None = None) -> TrainingCurve:
    """The trial's curves over its own lifetime episodes, with the games before its first
    (`origin`; default: `run_origin` of the trial's folder)."""
    trial = read_trial(trial)
    origin = run_origin(trial.path) if origin is None else origin
    rows = trial.rows
    returns_col = _column(rows, RETURN_COLUMNS)
    if returns_col is None:
        raise ValueError(f"{trial.path}: needs a return column (one of {list(RETURN_COLUMNS)})")
    means = _values(rows, returns_col)
    counts = _episode_counts(trial)
    known = np.isfinite(means)
    episodes = np.cumsum(counts)[known]
    counts = counts[known].astype(np.int64)
    kept = [row for row, k in zip(rows, known, strict=True) if k]
    stages = [_stage_of(row) for row in kept]

    def curve(values: np.ndarray) -> np.ndarray:
        return _phase_means(values, counts, stages, window)

    return TrainingCurve(trial.name, episodes, curve(means[known]), stages,
                         [str(row.get(REWARD_COLUMN) or "") for row in kept],
                         curve(_values(kept, "env_runners/learner_win")),
                         curve(_values(kept, "env_runners/learner_loss")),
                         curve(_values(kept, "env_runners/learner_kills")),
                         curve(_values(kept, "env_runners/learner_bombs")),
                         start=origin.games, origin=origin.policy)


MEMBER_PREFIX = "env_runners/learner_win_vs_"


def league_curves(trial: Trial | Path, window: int = MEMBER_WINDOW) -> LeagueCurves | None:
    """The learner's outcomes against each league member and the members' shares
    (viz/training.MemberCurves), or None for a trial that played no league. A row's outcome
    rates against a member are those of its iteration's games against it, weighted by their
    number (`league_games_vs_<member>`; runs that did not log it count one game a row)."""
    trial = read_trial(trial)
    rows = trial.rows
    names = list(dict.fromkeys(key.removeprefix(MEMBER_PREFIX) for row in rows for key in row
                               if key.startswith(MEMBER_PREFIX)))
    if not names:
        return None
    episodes = np.cumsum(_episode_counts(trial))
    members = {}
    for name in names:
        rates = {key: _values(rows, f"env_runners/learner_{key}_vs_{name}")
                 for key in OUTCOME_KEYS}
        played = np.isfinite(rates["win"])
        games = np.nan_to_num(_values(rows, f"env_runners/league_games_vs_{name}"))
        games = np.where(played, np.where(games > 0, games, 1), 0).astype(np.int64)
        curves = {key: rolling_mean(np.nan_to_num(values), games, window)
                  for key, values in rates.items()}
        members[name] = MemberCurves(**curves,
                                     share=_values(rows, f"matchmaking/{name}/share"))
    return LeagueCurves(trial.name, episodes, members)


def _phase_means(values: np.ndarray, counts: np.ndarray, stages: list[str],
                 window: int) -> np.ndarray:
    """`rolling_mean` restarted at each phase; a row without a value weighs nothing."""
    known = np.isfinite(values)
    values, counts = np.where(known, values, 0.0), np.where(known, counts, 0)
    means = np.full(len(values), np.nan)
    for start, end, _ in phases(stages):
        means[start:end] = rolling_mean(values[start:end], counts[start:end], window)
    return means


def _weighted_mean(values: np.ndarray, weights: np.ndarray) -> float:
    known = np.isfinite(values) & (weights > 0)
    return float(np.average(values[known], weights=weights[known])) if known.any() else math.nan


def _mean(values: np.ndarray) -> float:
    known = values[np.isfinite(values)]
    return float(known.mean()) if known.size else math.nan


def stage_figures(trial: Trial | Path) -> list[StageFigures]:
    trial = read_trial(trial)
    rows = trial.rows
    counts = _episode_counts(trial)
    steps = _increments(rows, "env_runners/num_env_steps_sampled_lifetime")
    seconds = _increments(rows, "time_total_s")
    runner = {name: _values(rows, f"env_runners/learner_{name}")
              for name in ("win", "loss", "tie", "override_share")}
    variance = _values(rows, "learners/learner/vf_explained_var")
    figures = []
    for start, end, stage in phases([_stage_of(row) for row in rows]):
        part = slice(start, end)
        rates = {name: _weighted_mean(values[part], counts[part])
                 for name, values in runner.items()}
        figures.append(StageFigures(
            trial.name, stage, end - start, int(counts[part].sum()),
            int(steps[part].sum()), float(seconds[part].sum()), **rates,
            explained_variance=(_mean(variance[part][:10]), _mean(variance[part][-10:]))))
    return figures


def _stage_of(row: dict) -> str:
    """The row's phase from the first of `STAGE_COLUMNS` it has (a run resumed by a newer version
    has the newer column from then on only)."""
    return next((str(row[c]) for c in STAGE_COLUMNS if row.get(c) not in (None, "")), "")


def run_training(paths: list[Path], summaries: Path | None = None) -> Training:
    """The training figures of the trial folders in or below `paths` (ValueError for a path
    with none); with `summaries`, also each trial's summary in `summaries`/<run name> (a trial
    folder this module reads again, `write_summary`)."""
    trials = []
    for path in paths:
        found = find_trials(path)
        if not found:
            raise ValueError(f"{path}: no Tune trial (progress.csv or result.json) in or below it")
        trials += found
    read = [read_trial(trial) for trial in trials]
    origins = [run_origin(trial) for trial in trials]
    named = Counter(trial.name for trial in read)
    for k, (trial, origin) in enumerate(zip(read, origins, strict=True) if summaries else ()):
        summary = write_summary(trial, summaries / (trial.name if named[trial.name] == 1
                                                    else f"{trial.name}_{k}"))
        write_origin(origin, summary)
    leagues = [league_curves(trial) for trial in read]
    return Training(trials, [training_curve(trial, origin=origin)
                             for trial, origin in zip(read, origins, strict=True)],
                    [f for trial in read for f in stage_figures(trial)],
                    [league for league in leagues if league is not None])


@dataclass(frozen=True)
class Origin:
    """Where a run's pi started: the shipped policy whose weights it started from (None: not
    known, or weights no shipped policy holds) and the games its lineage had trained, counted
    from the imitation clone (0 for the clone itself)."""

    policy: str | None = None
    games: int = 0


def run_origin(trial: Path) -> Origin:
    """The origin of the run a trial folder belongs to: the trial's `ORIGIN_FILE` (a summary's),
    else the shipped policy whose weights the run's curriculum names as `pi_weights`
    (`curriculum.run_curriculum` of the trial's parent folder), with the games of its `lineage`.
    A run whose curriculum cannot be read starts at 0, with a warning."""
    noted = Path(trial) / ORIGIN_FILE
    if noted.is_file():
        try:
            data = json.loads(noted.read_text())
            return Origin(data.get("policy"), int(data.get("games", 0)))
        except (ValueError, TypeError, AttributeError) as exc:
            raise ValueError(f"{noted}: unreadable ({exc})") from None
    try:
        curriculum = run_curriculum(Path(trial).parent)
    except (ValueError, OSError) as exc:
        warnings.warn(f"{trial}: drawn from 0 games, its curriculum is not readable ({exc})",
                      stacklevel=2)
        return Origin()
    policy = shipped_policy(curriculum.pi_weights) if curriculum else None
    return Origin(policy, sum(link["games"] for link in lineage(policy))) if policy else Origin()


def write_origin(origin: Origin, folder: Path) -> None:
    """Note `origin` in a trial folder (a summary), where `run_origin` reads it first."""
    (Path(folder) / ORIGIN_FILE).write_text(json.dumps(
        {"policy": origin.policy, "games": origin.games}) + "\n")


def shipped_policy(weights: Path) -> str | None:
    """The shipped learned policy whose weights file `weights` is (the one named like the
    weights' folder first, where two policy files play one weights file), None for any other
    file."""
    weights = Path(weights).resolve()
    for name in sorted(policy_names(), key=lambda name: name != weights.parent.name):
        spec = resolve_policy(name)
        if spec.kind == "learned" and spec.file("weights").resolve() == weights:
            return name
    return None


def lineage(policy: str | None) -> list[dict]:
    """The shipped policies pi descends from, oldest first, each with the games its own run
    trained it (`exported_training`); the chain ends at a policy no PPO run exported (the
    imitation clone), which counts 0, or at one whose export proved no start (`pi_start`). What
    the paper's game budget is counted against."""
    chain, seen = [], set()
    while policy and policy not in seen:
        seen.add(policy)
        folder = resolve_policy(policy).file("weights").parent
        try:
            source, training = exported_training(folder)
        except ValueError:
            chain.append({"policy": policy, "games": 0})
            break
        chain.append({"policy": policy, "games": sum(s.episodes for s in training.stages)})
        policy = source.get("pi_start")
    return chain[::-1]


def read_source(policy_dir: Path) -> dict:
    """An exported policy folder's `source.json`, with every key its card uses, or a ValueError
    naming the file and what is wrong."""
    path = Path(policy_dir) / POLICY_SOURCE_FILE
    try:
        source = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: not readable ({exc}); write it with `python -m "
                         f"rllib_pommer.train --out RUN --export {policy_dir}`") from None
    missing = [key for key in SOURCE_KEYS if not isinstance(source, dict) or key not in source]
    if missing:
        raise ValueError(f"{path}: missing {missing}")
    return source


def exported_training(policy_dir: Path) -> tuple[dict, Training]:
    """What an exported policy's model card is drawn from: its source and its one trial's
    training, from the policy folder alone."""
    source = read_source(policy_dir)
    history = Path(policy_dir) / POLICY_HISTORY_DIR
    trials = find_trials(history)
    if len(trials) != 1:
        raise ValueError(f"{history}: expected the summary of one trial, found {len(trials)}")
    if not read_trial(trials[0]).rows:
        raise ValueError(f"{trials[0]}: no training rows")
    return source, run_training(trials)
