"""The paper's Figs. 3-5 from our own runs, as PNG files.

Built on `matplotlib.figure.Figure`, which renders with Agg and touches no global pyplot state,
so figures can be made from any process or thread without a display.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from .behaviour import Heatmaps
from .matches import VARIANTS
from .paper import PAPER_OPPONENTS
from .training import MEMBER_WINDOW, RLLIB_WINDOW, WINDOW, LeagueCurves, TrainingCurve, phases

DPI = 120
# (name, index in a (win, loss, tie) cell, colour), in the order the bars are drawn.
OUTCOMES = (("win", 0, "#2e9e4f"), ("tie", 2, "#9a9a9a"), ("loss", 1, "#d43434"))
Rates = dict[str, dict[str, tuple[float, float, float]]]  # opponent -> variant -> cell


# Reward kind -> its axis' title; one axis each, so shaped and raw returns are never compared on
# one scale ("" : a run that did not log its kind). The rewards themselves: envs/team.py.
REWARD_AXES = {"shaped": "shaped reward (the paper's)", "raw": "raw reward (the engine's)",
               "shaped_credit": "shaped reward, credited kills only (ours)",
               "raw_kills": "raw reward + 0.5 a credited kill (ours)",
               "raw_kills_clock": "raw reward + 0.5 a credited kill - the clock (ours)",
               "raw_kills_room": "raw reward + 0.5 a credited kill + cornering (ours)",
               "raw_kills_trap": "raw reward + 0.5 a credited kill + trapping (ours)",
               "": "reward kind not logged"}


def run_colour(k: int) -> tuple:
    """The colour of a figure's k-th run: twenty, the ten dark ones of tab20 first."""
    return colormaps["tab20"]((2 * k + (k // 10) % 2) % 20)


def plot_training(curves: list[TrainingCurve], out: Path) -> Figure:
    """Fig. 3: each run's learner return, one axis per reward kind, one segment per curriculum
    phase with the phase names at their starts (what the mean is over: viz/training.py), over
    the games counted from the imitation clone: a run continued from a shipped policy starts
    where that policy's training ended (`TrainingCurve.start`)."""
    kinds = [kind for kind in REWARD_AXES if any(kind in curve.rewards for curve in curves)]
    unknown = sorted({kind for curve in curves for kind in curve.rewards} - set(REWARD_AXES))
    if unknown:
        raise ValueError(f"Fig. 3: unknown reward kind(s) {unknown}; known: {list(REWARD_AXES)}")
    kinds = kinds or [""]
    fig = Figure(figsize=(12, 1.6 + 4.2 * len(kinds)), layout="constrained")
    axes = dict(zip(kinds, fig.subplots(len(kinds), 1, sharex=True, squeeze=False)[:, 0],
                    strict=True))
    marks: dict = {ax: [] for ax in axes.values()}
    for k, curve in enumerate(curves):
        colour = run_colour(k)
        labelled = set()
        games = curve.start + curve.episodes
        for start, end, (stage, kind) in phases(list(zip(curve.stages, curve.rewards,
                                                         strict=True))):
            ax = axes[kind]
            ax.plot(games[start:end], curve.returns[start:end], color=colour,
                    label=None if kind in labelled else curve.name)
            labelled.add(kind)
            marks[ax].append((games[start], stage, colour))
    for kind, ax in axes.items():
        ax.set_title(REWARD_AXES[kind], fontsize=10)
        ax.set_ylabel(f"learner's return: {WINDOW:,}-episode\nmean of RLlib's "
                      f"{RLLIB_WINDOW}-episode means")
        ax.grid(alpha=0.3)
        _legend_beside(ax)
    axes[kinds[-1]].set_xlabel(_games_label(curves))
    fig.suptitle("Fig. 3: training reward per curriculum phase")
    _mark_phases(fig, marks)
    fig.savefig(out, dpi=DPI)
    return fig


def _games_label(curves: list[TrainingCurve]) -> str:
    """The x axis: games counted from the imitation clone, and where each continued run
    starts (the shipped policy it continued and that policy's games)."""
    starts: dict[tuple[str | None, int], list[str]] = {}
    for curve in curves:
        if curve.start:
            starts.setdefault((curve.origin, curve.start), []).append(curve.name)
    label = "training games, counted from the imitation clone"
    if not starts:
        return label
    continued = "; ".join(f"{', '.join(names)} from `{origin}` at {games:,}"
                          for (origin, games), names in sorted(starts.items(),
                                                               key=lambda item: item[0][1]))
    return "\n".join(textwrap.wrap(f"{label} (runs continued from a shipped policy start at its "
                                   f"games: {continued})", 150))


def plot_league(league: LeagueCurves, out: Path) -> Figure:
    """A league run member by member: the learner's win, tie and loss rates against each
    (over its last `MEMBER_WINDOW` games against it) and, under prioritized matchmaking, the
    member's share of the coming games on a second axis."""
    names = list(league.members)
    columns = min(4, len(names))
    rows = math.ceil(len(names) / columns)
    fig = Figure(figsize=(3.4 * columns, 1.2 + 2.4 * rows), layout="constrained")
    axes = fig.subplots(rows, columns, sharex=True, sharey=True, squeeze=False).ravel()
    for ax, name in zip(axes, names, strict=False):  # spare axes hidden below
        member = league.members[name]
        for outcome, _, colour in OUTCOMES:
            ax.plot(league.episodes, getattr(member, outcome), color=colour, label=outcome)
        if np.isfinite(member.share).any():
            share = ax.twinx()
            share.plot(league.episodes, member.share, color="black", linestyle=":",
                       label="share of games")
            share.set_ylim(0, max(0.3, float(np.nanmax(member.share)) * 1.1))
            share.tick_params(labelsize=7)
        ax.set_title(name, fontsize=9)
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
    for ax in axes[len(names):]:
        ax.set_visible(False)
    for ax in axes[len(names) - columns:len(names)]:
        ax.set_xlabel("training episodes (lifetime)", fontsize=8)
    handles = [Line2D([], [], color=colour, label=outcome) for outcome, _, colour in OUTCOMES]
    if any(np.isfinite(member.share).any() for member in league.members.values()):
        handles.append(Line2D([], [], color="black", linestyle=":",
                              label="share of the coming games (right axis)"))
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), fontsize=8)
    fig.suptitle(f"{league.name}: the learner against each league member (its last "
                 f"{MEMBER_WINDOW} games against it)")
    fig.savefig(out, dpi=DPI)
    return fig


def _legend_beside(ax) -> None:
    """The axis's legend right of it, off the curves (a report draws a dozen runs)."""
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))


PHASE_FONT = 7  # points
LABEL_BAND = 0.45  # the part of an axis, from its top, that phase names may take


def _mark_phases(fig: Figure, marks: dict) -> None:
    """Where each curriculum phase starts: a dotted line in its run's colour, its name near the
    top. A name that several runs start at one place is written once, in grey; the others take
    the highest lane (a row of names on their sides, one name long) where no name stands within
    a name's width, or, with every lane taken there, the lane whose last name is furthest left,
    just right of it: no two names overlap (`marks`: per axis, the (games, phase, colour) of
    each phase start)."""
    fig.draw_without_rendering()  # the lanes need each axis' size as laid out
    for ax, found in marks.items():
        per_pixel = _data_per_pixel(ax)
        named: dict[tuple[float, str], str] = {}
        for games, stage, colour in sorted(found, key=lambda mark: (mark[1], mark[0])):
            if not stage:
                continue
            ax.axvline(games, color=colour, linestyle=":", linewidth=1)
            near = next((key for key in named
                         if key[1] == stage and abs(key[0] - games) < PHASE_FONT * per_pixel),
                        None)
            if near is None:
                named[games, stage] = colour
            elif named[near] != colour:
                named[near] = "0.35"
        texts = {key: ax.annotate(key[1], (key[0], 0.98), rotation=90, ha="right", va="top",
                                  fontsize=PHASE_FONT, color=colour,
                                  xycoords=("data", "axes fraction"))
                 for key, colour in sorted(named.items())}
        if not texts:
            continue
        sizes = [text.get_window_extent() for text in texts.values()]  # in pixels, as drawn
        width = max(size.width for size in sizes) + 1
        height = (max(size.height for size in sizes) + 4) / ax.get_window_extent().height
        last = [-math.inf] * min(max(2, int(LABEL_BAND // height)), max(1, int(0.98 // height)))
        used = 0
        for (games, _), text in texts.items():
            x = games / per_pixel
            free = [lane for lane in range(len(last)) if x - last[lane] >= width]
            lane = free[0] if free else int(np.argmin(last))
            last[lane] = x = max(x, last[lane] + width)  # no lane free: just right of the last
            used = max(used, lane + 1)
            text.xy = text.xyann = (x * per_pixel, 0.98 - lane * height)
            text.set_in_layout(False)
        _make_room(ax, min(0.9, used * height + 0.02))


def _make_room(ax, band: float) -> None:
    """Raise the axis' top so that the curves stay below its top `band` (a fraction of the
    axis), where the phase names stand; the ticks stay those of the curves' range."""
    low, high = ax.get_ylim()
    ticks = [tick for tick in ax.get_yticks() if low <= tick <= high]
    ax.set_ylim(low, low + (high - low) / (1 - band))
    ax.set_yticks(ticks)


def _data_per_pixel(ax) -> float:
    low, high = ax.get_xlim()
    return (high - low) / max(ax.get_window_extent().width, 1.0)


# The panels below the outcomes: (TrainingCurve field, axis label, axis top).
OUTCOME_PANELS = (("kills", "enemies killed per game", 2),
                  ("bombs", "bombs laid per agent per game", 20))


def plot_outcomes(curves: list[TrainingCurve], out: Path) -> Figure:
    """Beside Fig. 3: each run's training win rate (solid) and loss rate (dashed; the legend
    names each run once, then the two styles), the same
    rolling means per phase; one scale for every run, whatever its reward. Below, where some run
    logs them, one panel each for the enemies its team killed per game (game/kills.py) and the
    bombs each learner agent laid per game: a run that learns to hide lays none."""
    below = [(field, label, top) for field, label, top in OUTCOME_PANELS
             if any(np.isfinite(getattr(curve, field)).any() for curve in curves)]
    fig = Figure(figsize=(12, 6.4 + 3.0 * len(below)), layout="constrained")
    ax, *panels = fig.subplots(1 + len(below), 1, sharex=True, squeeze=False,
                               height_ratios=[5.4] + [3.0] * len(below))[:, 0]
    for panel, (field, label, top) in zip(panels, below, strict=True):
        for k, curve in enumerate(curves):
            if np.isfinite(getattr(curve, field)).any():
                panel.plot(curve.start + curve.episodes, getattr(curve, field),
                           color=run_colour(k), label=curve.name)
        panel.set_ylabel(f"{label}\n(the same rolling means)")
        panel.set_ylim(0, top)
        panel.grid(alpha=0.3)
        _legend_beside(panel)
    marks = []
    for k, curve in enumerate(curves):
        colour = run_colour(k)
        games = curve.start + curve.episodes
        for n, (start, end, stage) in enumerate(phases(curve.stages)):
            part = slice(start, end)
            ax.plot(games[part], curve.wins[part], color=colour,
                    label=None if n else curve.name)
            ax.plot(games[part], curve.losses[part], color=colour, linestyle="--")
            marks.append((games[start], stage, colour))
    ax.set_ylim(0, 1)
    ax.set_ylabel(f"learner's team: {WINDOW:,}-episode\nmean of RLlib's {RLLIB_WINDOW}-episode "
                  f"rates")
    (panels or [ax])[-1].set_xlabel(_games_label(curves))
    ax.grid(alpha=0.3)
    handles, names = ax.get_legend_handles_labels()
    ax.legend(handles + [Line2D([], [], color="black", label="win"),
                         Line2D([], [], color="black", linestyle="--", label="loss")],
              names + ["win", "loss"], fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.suptitle("Training win and loss rates per curriculum phase (beside Fig. 3)")
    _mark_phases(fig, {ax: marks})
    fig.savefig(out, dpi=DPI)
    return fig


def _change(cells: dict, variant: str, index: int) -> float:
    """Percentage-point change of one outcome from vanilla to `variant` (NaN if unknown)."""
    if cells.get("vanilla") is None or cells.get(variant) is None:
        return math.nan
    return 100 * (cells[variant][index] - cells["vanilla"][index])


def comparable_opponents(ours: Rates) -> list[str]:
    """Opponents met by the vanilla team and by at least one filtered variant."""
    return [vs for vs, cells in ours.items() if "vanilla" in cells and len(cells) > 1]


def plot_filter_effects(ours: Rates, paper: Rates, title: str, out: Path) -> None:
    """Fig. 4: per opponent, the change in win/tie/loss rates when jitter correction, the action
    filter or both are added; our bars, the paper's changes as black diamonds."""
    opponents = comparable_opponents(ours)
    if not opponents:
        raise ValueError("Fig. 4 needs, for some opponent, a vanilla and a filtered match")
    columns = min(3, len(opponents))
    fig = Figure(figsize=(4.2 * columns, 3.4 * math.ceil(len(opponents) / columns) + 0.6),
                 layout="constrained")
    axes = fig.subplots(math.ceil(len(opponents) / columns), columns, squeeze=False, sharey=True)
    filtered = VARIANTS[1:]
    x = np.arange(len(filtered))
    width = 0.26
    for ax, vs in zip(axes.flat, opponents, strict=False):  # spare axes are hidden
        for k, (_, index, colour) in enumerate(OUTCOMES):
            offset = x + (k - 1) * width
            ax.bar(offset, [_change(ours[vs], v, index) for v in filtered], width, color=colour)
            ax.scatter(offset, [_change(paper.get(vs, {}), v, index) for v in filtered],
                       marker="D", s=16, color="black", zorder=3)
        ax.axhline(0, color="black", linewidth=0.8)
        ax.set_xticks(x, filtered)
        ax.set_title(f"vs {PAPER_OPPONENTS.get(vs, vs)}", fontsize=10)
        ax.grid(axis="y", alpha=0.3)
    for ax in axes.flat[len(opponents):]:
        ax.set_visible(False)
    for ax in axes[:, 0]:
        ax.set_ylabel("change from vanilla (points)")
    handles = [Patch(color=colour, label=name) for name, _, colour in OUTCOMES]
    handles.append(Line2D([], [], marker="D", color="black", linestyle="", label="paper"))
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles))
    fig.suptitle(title)
    fig.savefig(out, dpi=DPI)


FIG5_MARKS = ("Every seat is mirrored to start top-left; the blue circle marks that start cell.\n"
              "Colour: the cell's share of all the team's agent-steps (left) or of all its bombs "
              "(right), in %.")


def plot_behaviour(maps: dict[tuple[str, str], Heatmaps], out: Path) -> Figure:
    """Fig. 5: per (our policy, opponent), where our agents stood and where they laid bombs, as
    shares of all their steps and bombs, every seat mirrored to start top-left (circled). One row
    per policy (named at its left), two columns per opponent; a pair not played stays blank."""
    teams = list(dict.fromkeys(team for team, _ in maps))
    opponents = list(dict.fromkeys(vs for _, vs in maps))
    fig = Figure(figsize=(3.1 * 2 * len(opponents), 2.9 * len(teams) + 0.9), layout="constrained")
    axes = fig.subplots(len(teams), 2 * len(opponents), squeeze=False)
    for ax in axes.flat:
        ax.set_axis_off()
    for (team, vs), heatmaps in maps.items():
        row, column = teams.index(team), 2 * opponents.index(vs)
        for ax, counts, what in ((axes[row, column], heatmaps.positions, "positions"),
                                 (axes[row, column + 1], heatmaps.bombs, "bomb placements")):
            ax.set_axis_on()
            image = ax.imshow(100 * counts / max(counts.sum(), 1), cmap="magma")
            ax.plot(1, 1, marker="o", markersize=10, markerfacecolor="none",
                    markeredgecolor="#4fc3f7")
            ax.set_title(f"vs {PAPER_OPPONENTS.get(vs, vs)}: {what}\n"
                         f"{heatmaps.games} games, {counts.sum()} in all", fontsize=9)
            ax.set_xticks(np.arange(-0.5, counts.shape[1]), minor=True)
            ax.set_yticks(np.arange(-0.5, counts.shape[0]), minor=True)
            ax.grid(which="minor", color="#444", linewidth=0.5)
            ax.tick_params(which="both", length=0, labelbottom=False, labelleft=False)
            fig.colorbar(image, ax=ax, shrink=0.8, label=f"% of {what}")
    for row, team in zip(axes, teams, strict=True):
        row[0].set_axis_on()
        row[0].set_ylabel(team, fontsize=12, fontweight="bold")
    fig.suptitle(f"Fig. 5: positions and bomb placements of {', '.join(teams)}")
    fig.supxlabel(FIG5_MARKS, fontsize=8)
    fig.savefig(out, dpi=DPI)
    return fig
