"""`python -m rllib_pommer.replay`: check recorded games against our engine and agents.

    verify FILE...   replay every game step by step and compare; the last line is
                     `verified G games, S steps, M mismatches` (exit 0 iff M == 0)
    agree FILE --decisions DECISIONS.json [--policy NAME]
                     feed each SimpleAgent seat's recorded observations to a policy (default our
                     SimpleAgent); the last line is `agreement A on N decisions; stable S on K
                     decisions`
    render FILE [--game K] --out OUT.png|OUT.gif [--step T]  [--fog AGENT]
                     draw game K: one step as a PNG (default the last) or every step as a GIF,
                     in full or as agent AGENT sees it
    html FILE [--game K] --out game.html
                     write a self-contained replay viewer (play/pause, step slider, speed, fog)

render and html refuse an existing --out file unless given --force.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .agents.agreement import format_line, measure_agreement
from .game.records import read_games
from .game.verify import verify_games
from .util.errors import report_error
from .util.outputs import check_output
from .viz.frames import load_game
from .viz.render import render_game
from .viz.viewer import write_viewer


def _verify(args: argparse.Namespace) -> int:
    def records():
        for path in args.files:
            empty = True
            for record in read_games(path):
                empty = False
                yield record
            if empty:
                raise ValueError(f"{path}: no game records: nothing to verify")

    report = verify_games(records())
    for mismatch in report.mismatches[: args.max_report]:
        print(mismatch)
    if len(report.mismatches) > args.max_report:
        print(f"... {len(report.mismatches) - args.max_report} more mismatches not shown")
    print(report.summary())
    return 0 if not report.mismatches else 1


def _agree(args: argparse.Namespace) -> int:
    result = measure_agreement(args.file, args.decisions, args.policy)
    print(f"reference SimpleAgents agree with the recorded actions on {result.reference_mean:.4f}")
    print(format_line(result))
    return 0


def _render(args: argparse.Namespace) -> int:
    check_output(args.out, "--out", args.force)
    count = render_game(load_game(args.file, args.game), args.out, args.step, args.fog, args.fps)
    print(f"wrote {args.out} ({count} frame{'s' if count > 1 else ''})")
    return 0


def _html(args: argparse.Namespace) -> int:
    check_output(args.out, "--out", args.force)
    write_viewer(load_game(args.file, args.game), args.out)
    print(f"wrote {args.out}")
    return 0


def _positive_fps(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = 0.0
    if not 0 < value <= 100:  # a GIF frame lasts at least 10 ms
        raise argparse.ArgumentTypeError(f"must be in (0, 100] steps per second, got {text}")
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.replay", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    verify = sub.add_parser("verify", help="replay recorded games and compare every step")
    verify.add_argument("files", nargs="+", help="games as .jsonl or .jsonl.gz")
    verify.add_argument("--max-report", type=int, default=50, help="mismatch lines to print")
    verify.set_defaults(run=_verify)
    agree = sub.add_parser("agree", help="SimpleAgent decision agreement on recorded games")
    agree.add_argument("file", help="games as .jsonl or .jsonl.gz")
    agree.add_argument("--decisions", required=True, help="the reference decisions .json")
    agree.add_argument("--policy", default="simple",
                       help="the policy measured (a name or policy file; default simple)")
    agree.set_defaults(run=_agree)
    render = sub.add_parser("render", help="draw a recorded game as a PNG (one step) or a GIF")
    render.add_argument("file", help="games as .jsonl or .jsonl.gz")
    render.add_argument("--game", type=int, default=0, help="which game of the file, from 0")
    render.add_argument("--out", type=Path, required=True, help="OUT.png or OUT.gif")
    render.add_argument("--step", type=int, help="the PNG's step, from 0 (default: the last)")
    render.add_argument("--fog", type=int, metavar="AGENT", help="show what AGENT sees")
    render.add_argument("--fps", type=_positive_fps, default=8, help="GIF steps per second")
    render.add_argument("--force", action="store_true", help="replace an existing --out file")
    render.set_defaults(run=_render)
    html = sub.add_parser("html", help="write a self-contained HTML replay viewer")
    html.add_argument("file", help="games as .jsonl or .jsonl.gz")
    html.add_argument("--game", type=int, default=0, help="which game of the file, from 0")
    html.add_argument("--out", type=Path, required=True, help="the .html file to write")
    html.add_argument("--force", action="store_true", help="replace an existing --out file")
    html.set_defaults(run=_html)
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except (ValueError, OSError) as exc:
        return report_error(exc)


if __name__ == "__main__":
    sys.exit(main())
