"""The report of `python -m rllib_pommer.report`: inputs classified by what they hold, then the
paper's figures and tables drawn from them into one folder (report.md and PNGs). Runs come as
their training figures, computed by the job with `runs/history.py` (viz/ reads no run history)."""

from __future__ import annotations

import csv
import re
from collections.abc import Iterator
from pathlib import Path

from ..arena.ladder import LADDER_FILE
from ..game.records import read_games, read_jsonl
from .behaviour import heatmaps_by_opponent
from .endings import endings_table, load_endings
from .figures import (
    FIG5_MARKS,
    comparable_opponents,
    plot_behaviour,
    plot_filter_effects,
    plot_league,
    plot_outcomes,
    plot_training,
)
from .frames import load_game
from .ladder import ladder_section
from .matches import ROW_KEYS, load_outcomes, rates_by_opponent
from .paper import FIG3_CLAIMS, paper_table
from .render import render_game
from .tables import milestones_table, phase_progress_table, results_table, training_table
from .training import MEMBER_WINDOW, RLLIB_WINDOW, WINDOW, Training, TrainingCurve
from .viewer import write_viewer

UNSAFE_IN_NAMES = re.compile(r"[^\w.-]+")
SUMMARIES = "runs"  # below the report's folder: one small trial folder per run of Fig. 3


def kind_of(path: Path) -> str:
    """"ladder" (a ladder job's folder), "runs" (another directory: Tune trials in or below
    it), "records" (arena rows) or "replays", from what the path holds."""
    if path.is_dir():
        return "ladder" if (path / LADDER_FILE).is_file() else "runs"
    if path.suffix == ".csv":
        with open(path, newline="") as f:
            first = dict.fromkeys(next(csv.reader(f), []))
    else:
        first = next(read_jsonl(path), {})
    if "initial_state" in first and "steps" in first:
        return "replays"
    if set(first) >= ROW_KEYS:
        return "records"
    raise ValueError(f"{path}: neither arena records ({sorted(ROW_KEYS)} ...) nor game replays")


def classify(paths: list[Path]) -> dict[str, list[Path]]:
    found: dict[str, list[Path]] = {"runs": [], "records": [], "replays": [], "ladder": []}
    for path in paths:
        found[kind_of(path)].append(path)
    return found


def tables_section(records: list[Path], out: Path) -> Iterator[str]:
    """Tables 2 and 3 beside the paper's, and Fig. 4 per team (PNGs into `out`)."""
    outcomes = load_outcomes(records)
    yield "## Win / loss / tie (the paper's Tables 2 and 3)"
    yield ("Each cell: team A's win / loss / tie rates; ours over n games with their 95% Wilson "
           "intervals below them, the paper's over 1000 games last. Variants add jitter "
           "correction and/or the action filter.")
    endings = load_endings(records)
    for team in sorted({match.team for match in outcomes}):
        yield results_table(team, outcomes)
        if ended := endings_table(team, endings):
            yield ended
        ours = rates_by_opponent(outcomes, team)
        if comparable_opponents(ours):
            name = f"fig4_filters_{UNSAFE_IN_NAMES.sub('_', team)}.png"  # a team may be a path
            paper = (paper_table(team) or ("", {}))[1]
            plot_filter_effects(ours, paper, f"Fig. 4: effect of the filters on {team}", out / name)
            yield f"![Fig. 4 for {team}]({name})"


def fig3_section(training: Training, out: Path, summaries: str = "") -> Iterator[str]:
    """Fig. 3 and the stage table of `training` (PNGs into `out`); `summaries`: the folder below
    `out` where the job kept each trial's rows, small (a card's trials are kept already)."""
    plot_training(training.curves, out / "fig3_training.png")
    plot_outcomes(training.curves, out / "fig3_outcomes.png")
    yield "## Training reward (the paper's Fig. 3)"
    paths = training.trials
    shown = [path.relative_to(out) if path.is_relative_to(out) else path for path in paths]
    yield f"From {len(paths)} trial(s): " + ", ".join(f"`{path}`" for path in shown)
    yield "![Fig. 3](fig3_training.png)"
    yield (f"One axis per reward kind (shaped and raw returns are not on one scale). Each "
           f"iteration logs RLlib's mean return of the learner's last {RLLIB_WINDOW} episodes; "
           f"a curve averages those over the last {WINDOW:,} episodes (each iteration weighted "
           f"by the episodes it finished), restarted at each phase.")
    yield "![training win and loss rates](fig3_outcomes.png)"
    yield ("The same means of the learner's team's win and loss rates: one scale for every "
           "run, whatever reward it was paid; below, where runs log them, the enemies its team "
           "killed and the bombs each learner agent laid per game (a run that learns to hide "
           "stops laying bombs).")
    if len(training.curves) > 1:
        yield ("Where each run stood after the same numbers of games: the win / loss means "
               "above (and, where logged, enemies its team killed and bombs each of its learner "
               "agents laid per game), with the phase in "
               "force; runs meet different opponents at the same count, so read the phase too.")
        yield milestones_table(training.curves)
        yield ("How fast each run learned within a phase: the same means counted from the "
               "phase's first game (the window restarts with it), rows of one phase together, "
               "so runs that meet an opponent at different points of their lives compare from "
               "their first game against it.")
        yield phase_progress_table(training.curves)
        yield from fig3_readings(training.curves)
    yield training_table(training.stages)
    yield from league_section(training, out)
    if summaries:
        yield (f"Each run's curve and training figures per iteration are in `{summaries}/<run>/"
               f"progress.csv` (a trial folder this report reads again).")


def league_section(training: Training, out: Path) -> Iterator[str]:
    """Each league run's outcomes against each member (and their shares under prioritized
    matchmaking), one PNG a run."""
    if not training.leagues:
        return
    yield "## The learner against each league member"
    yield (f"Win, tie and loss rates of the learner's team against each member over its last "
           f"{MEMBER_WINDOW} games against it; under prioritized matchmaking, the dotted line "
           f"is the member's share of the coming games (right axis).")
    for k, league in enumerate(training.leagues):
        name = f"league_{k}_{league.name}.png"
        plot_league(league, out / name)
        yield f"![{league.name} against each league member]({name})"


def fig3_readings(curves: list[TrainingCurve]) -> Iterator[str]:
    """Each reading of the paper's Fig. 3, with the phase rows of the runs here that test it."""
    yield "What the paper reads in its Fig. 3, each beside the phase rows that test it here:"
    for claim in FIG3_CLAIMS:
        tested = [curve for curve in curves if curve.name in claim.runs]
        note = f" ({claim.note})" if claim.note else ""
        runs = ", ".join(f"`{run}`" for run in claim.runs)
        phases = ", ".join(f"`{phase}`" for phase in claim.phases)
        yield f"*The paper:* {claim.reading} *Here*, {runs} in {phases}{note}:"
        if any(stage in claim.phases for curve in tested for stage in curve.stages):
            yield phase_progress_table(tested, only=claim.phases)
        else:
            yield "none of these runs reached these phases."


def _fig5_and_game(replays: list[Path], out: Path) -> Iterator[str]:
    maps = heatmaps_by_opponent(record for path in replays for record in read_games(path))
    plot_behaviour(maps, out / "fig5_behaviour.png")
    yield "## Positions and bomb placements (the paper's Fig. 5)"
    yield "![Fig. 5](fig5_behaviour.png)"
    yield FIG5_MARKS.replace("\n", " ")
    first = load_game(replays[0])
    render_game(first, out / "game.png")
    write_viewer(first, out / "game.html")
    yield "## A game"
    yield (f"The last step of the first game of `{replays[0]}`; "
           "[watch it step by step](game.html) (a self-contained page).")
    yield "![the last step of a game](game.png)"


def write_report(out: Path, found: dict[str, list[Path]], training: Training | None) -> Path:
    """Draw what the inputs allow (`found`: the inputs by `classify`; `training`: the figures of
    its runs, whose trials the job summarised in `out`/`SUMMARIES`) and write `out`/report.md."""
    out.mkdir(parents=True, exist_ok=True)
    parts = ["# Report: our runs in the paper's figures and tables"]
    sections = (("records", found["records"], tables_section),
                ("ladder", found["ladder"], ladder_section),
                ("trials", training, lambda given, out: fig3_section(given, out, SUMMARIES)),
                ("replays", found["replays"], _fig5_and_game))
    for kind, given, section in sections:
        parts += list(section(given, out)) if given else [f"_No {kind} among the inputs._"]
    report = out / "report.md"
    report.write_text("\n\n".join(parts) + "\n")
    return report
