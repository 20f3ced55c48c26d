"""A ladder drawn: its table (Markdown) and its plot (PNG, each rating with its 95% interval),
for the ladder job's folder and for the report (`arena/ladder.py` computes them)."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path

from matplotlib.figure import Figure

from ..arena.ladder import LADDER_FILE, PLAIN_LADDER_FILE, Standing, read_ladder
from .figures import DPI


def ladder_table(settings: dict, standings: Sequence[Standing]) -> str:
    """One row per policy, best first: rating, interval, games and wins / losses / ties."""
    lines = [f"Round robin of {len(standings)} policies, {settings['games_per_pair']} games a "
             f"pair (seats balanced), seed {settings['seed']}. Ratings in Elo-like points "
             f"(a Bradley-Terry fit, a tie counted as half a win; mean 0 over the "
             f"ladder): 200 points above a policy means an expected score (a win plus half a "
             f"tie) of 0.76 against it. Intervals: 95% percentile bootstrap over games, "
             f"{settings['bootstrap']} replicates.", "",
             "| # | policy | rating | 95% interval | games | win / loss / tie |",
             "|---:|---|---:|---|---:|---|"]
    for k, s in enumerate(standings, 1):
        interval = ("won every game" if s.win == s.games else "lost every game"
                    if s.loss == s.games else f"[{s.low:+.0f}, {s.high:+.0f}]")
        lines.append(f"| {k} | `{s.policy}` | {s.rating:+.0f} | {interval} | {s.games} | "
                     f"{s.win} / {s.loss} / {s.tie} |")
    return "\n".join(lines)


def plot_ladder(standings: Sequence[Standing], title: str, out: Path) -> Figure:
    """Each policy's rating as a point with its interval as a bar, best at the top."""
    fig = Figure(figsize=(7, 1.2 + 0.38 * len(standings)), layout="constrained")
    ax = fig.subplots()
    rows = list(reversed(standings))
    y = range(len(rows))
    ax.errorbar([s.rating for s in rows], y, fmt="o", color="C0", capsize=3,
                xerr=[[s.rating - s.low for s in rows], [s.high - s.rating for s in rows]])
    ax.set_yticks(list(y), [s.policy for s in rows])
    ax.axvline(0, color="#9a9a9a", linewidth=1, linestyle=":")
    ax.set_xlabel("rating (Elo-like points, mean 0) with its 95% interval")
    ax.grid(axis="x", alpha=0.3)
    ax.set_title(title, fontsize=10)
    fig.savefig(out, dpi=DPI)
    return fig


def draw_ladder(folder: Path, out: Path, name: str = "ladder.png",
                file: str = LADDER_FILE) -> tuple[str, str]:
    """The ladder of `folder` (its ladder `file`) plotted as `out`/`name`: the Markdown of the
    picture, and the table."""
    settings, standings = read_ladder(folder / file)
    view = " (policies without filters)" if file == PLAIN_LADDER_FILE else ""
    plot_ladder(standings, f"Ladder{view}: {settings['games_per_pair']} games a pair, "
                           f"seed {settings['seed']}", out / name)
    return f"![the ladder{view}]({name})", ladder_table(settings, standings)


def draw_ladders(folder: Path, out: Path, stem: str = "ladder") -> Iterator[str]:
    """The folder's ladder, then its view without filters where the ladder has one (each a
    picture and a table, PNGs into `out`)."""
    yield from draw_ladder(folder, out, f"{stem}.png")
    if (folder / PLAIN_LADDER_FILE).is_file():
        yield ("The same games, fitted over the policies that play without the paper's "
               "filters only, so that no place comes from a filtered variant of one agent:")
        yield from draw_ladder(folder, out, f"{stem}_no_filters.png", PLAIN_LADDER_FILE)


def ladder_section(folders: list[Path], out: Path) -> Iterator[str]:
    """The report's section: each ladder folder's plots (PNGs into `out`) and tables."""
    yield "## The ladder"
    for k, folder in enumerate(folders):
        yield f"From `{folder}`:"
        yield from draw_ladders(folder, out, "ladder" if len(folders) == 1 else f"ladder_{k}")
