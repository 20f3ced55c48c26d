"""`python -m rllib_pommer.replay`: check recorded games against our engine and agents.

    verify FILE...   replay every game step by step and compare; the last line is
                     `verified G games, S steps, M mismatches` (exit 0 iff M == 0)
    agree FILE --decisions DECISIONS.json
                     feed each SimpleAgent seat's recorded observations to our SimpleAgent; the
                     last line is `agreement A on N decisions; stable S on K decisions`
"""

from __future__ import annotations

import argparse
import sys

from .agents.agreement import format_line, measure_agreement
from .game.records import read_games
from .game.verify import verify_games


def _verify(args: argparse.Namespace) -> int:
    def records():
        for path in args.files:
            yield from read_games(path)

    report = verify_games(records())
    for mismatch in report.mismatches[: args.max_report]:
        print(mismatch)
    if len(report.mismatches) > args.max_report:
        print(f"... {len(report.mismatches) - args.max_report} more mismatches not shown")
    print(report.summary())
    return 0 if not report.mismatches else 1


def _agree(args: argparse.Namespace) -> int:
    result = measure_agreement(args.file, args.decisions)
    print(f"reference SimpleAgents agree with the recorded actions on {result.reference_mean:.4f}")
    print(format_line(result))
    return 0


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
    agree.set_defaults(run=_agree)
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
