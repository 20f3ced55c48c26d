"""Win/loss/tie tables in the paper's layout (Tables 2 and 3): rows are opponents, columns the
four variants, each cell win / loss / tie; ours over n games with their 95% Wilson intervals and,
where the records carry kill credit, per game the opponents we killed, the opponents' suicides,
ours, and our bombs per agent; the paper's (1000 games) below. And
the training tables: what each curriculum phase of each run cost and how the learner did, and
where each run stood after the same numbers of games, and how fast each learned within a phase
(the reading of Fig. 3 across runs)."""

from __future__ import annotations

import math

from .matches import VARIANTS, Match, Outcomes
from .paper import PAPER_OPPONENTS, paper_table
from .training import StageFigures, TrainingCurve, phases

MILESTONES = (5_000, 10_000, 20_000, 30_000, 40_000, 60_000, 100_000)  # games, for milestones_table
PHASE_MARKS = (1_000, 2_500, 5_000, 10_000, 20_000, 40_000)  # games into a phase


def _rates(cell) -> str:
    return " / ".join(f"{x:.3f}" for x in cell)


def _intervals(intervals) -> str:
    return " / ".join(f"[{low:.3f}, {high:.3f}]" for low, high in intervals)


def _kills(outcomes: Outcomes) -> str:
    per_game = outcomes.per_game()
    if per_game is None:
        return ""
    return (f"<br>kills {per_game['kills_a']:.2f}, their suicides {per_game['suicides_b']:.2f}, "
            f"ours {per_game['suicides_a']:.2f}, bombs {per_game['bombs_per_agent_a']:.1f}")


def results_table(team: str, results: dict[Match, Outcomes]) -> str:
    """The Markdown table of `team` (policy name without filters), beside the paper's if any."""
    ours = {(m.vs, m.variant): o for m, o in results.items() if m.team == team}
    title, paper_rows = paper_table(team) or (None, {})
    opponents = list(paper_rows) + sorted({vs for vs, _ in ours} - set(paper_rows))
    heading = f"{title} — ours: `{team}`" if title else f"Team `{team}` (not in the paper)"
    lines = [f"### {heading}", "",
             "| opponent | " + " | ".join(VARIANTS) + " |", "|---" * (1 + len(VARIANTS)) + "|"]
    for vs in opponents:
        cells = []
        for variant in VARIANTS:
            mine = ours.get((vs, variant))
            text = (f"{_rates(mine.rates())} (n={mine.games})<br>{_intervals(mine.intervals())}"
                    f"{_kills(mine)}" if mine else "—")
            paper = paper_rows.get(vs, {}).get(variant)
            cells.append(text + (f"<br>paper {_rates(paper)}" if paper else ""))
        lines.append(f"| {PAPER_OPPONENTS.get(vs, vs)} (`{vs}`) | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _figure(value: float, digits: int = 3, unit: str = "") -> str:
    return "—" if math.isnan(value) else f"{value:.{digits}f}{unit}"


def training_table(figures: list[StageFigures]) -> str:
    """One row per run and curriculum phase."""
    lines = ["| run | stage | iterations | episodes | env steps | hours | env steps/s | "
             "learner win / loss / tie | actions the filters overrode | value net explained "
             "variance, first → last 10 iterations |", "|---" * 10 + "|"]
    for f in figures:
        rate = f.env_steps / f.seconds if f.seconds > 0 else math.nan
        lines.append(
            f"| {f.run} | {f.stage or '—'} | {f.iterations} | {f.episodes:,} | {f.env_steps:,} | "
            f"{f.seconds / 3600:.2f} | {_figure(rate, 0)} | {_figure(f.win)} / "
            f"{_figure(f.loss)} / {_figure(f.tie)} | {_figure(100 * f.override_share, 2, '%')} | "
            f"{_figure(f.explained_variance[0], 2)} → {_figure(f.explained_variance[1], 2)} |")
    return "\n".join(lines)


def _outcome(curve: TrainingCurve, i: int) -> str:
    """Row `i` of `curve`: win / loss, and kills and bombs per game where logged."""
    kills = "" if math.isnan(curve.kills[i]) else f", kills {curve.kills[i]:.2f}"
    bombs = "" if math.isnan(curve.bombs[i]) else f", bombs {curve.bombs[i]:.1f}"
    return f"{_figure(curve.wins[i], 2)} / {_figure(curve.losses[i], 2)}{kills}{bombs}"


def milestones_table(curves: list[TrainingCurve], milestones=MILESTONES) -> str:
    """One row per run, one column per number of games any run reached: the curves' rolling
    win / loss rates (and kills and bombs per game where logged) at the run's last row within
    that many games, and the phase it was in; "—" where the run had not got there."""
    reached = [m for m in milestones if any(len(c.episodes) and c.episodes[-1] >= m
                                            for c in curves)]
    lines = ["| run | " + " | ".join(f"{m:,} games" for m in reached) + " |",
             "|---" * (len(reached) + 1) + "|"]
    for curve in curves:
        cells = []
        for m in reached:
            rows = (curve.episodes <= m).nonzero()[0]
            if not len(curve.episodes) or curve.episodes[-1] < m or not len(rows):
                cells.append("—")
                continue
            i = rows[-1]
            cells.append(f"{_outcome(curve, i)} ({curve.stages[i] or '—'})")
        lines.append(f"| {curve.name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def phase_progress_table(curves: list[TrainingCurve], marks=PHASE_MARKS,
                         only: tuple[str, ...] | None = None) -> str:
    """How fast each run learned within each phase: one row per run and named phase (`only`:
    those phases alone), rows of the same phase together, one column per number of games into
    the phase that some phase reached, and the phase's end. A cell is the rolling win / loss
    (and kills and bombs) at the phase's last row within that many of its games (the window
    restarts with the phase); "—" where the phase did not get there. Runs that meet the same
    opponent at different points of their lives are compared from their first game against it."""
    spans = []  # (stage, curve, first row, end row, episodes before the phase)
    for curve in curves:
        for start, end, stage in phases(curve.stages):
            if stage and (only is None or stage in only):
                spans.append((stage, curve, start, end,
                              curve.episodes[start - 1] if start else 0.0))
    spans.sort(key=lambda span: (span[0], span[1].name))
    reached = [m for m in marks
               if any(c.episodes[end - 1] - before >= m for _, c, _, end, before in spans)]
    lines = ["| phase | run | " + " | ".join(f"{m:,} games in" for m in reached)
             + " | at its end |", "|---" * (len(reached) + 3) + "|"]
    for stage, curve, start, end, before in spans:
        games = curve.episodes[start:end] - before
        cells = []
        for m in reached:
            rows = (games <= m).nonzero()[0]
            cells.append(_outcome(curve, start + rows[-1]) if games[-1] >= m and len(rows)
                         else "—")
        cells.append(f"{_outcome(curve, end - 1)} ({games[-1]:,.0f} games)")
        lines.append(f"| {stage} | {curve.name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
