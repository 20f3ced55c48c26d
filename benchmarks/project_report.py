"""Redraw `docs/report/` from what the repository holds, with one command:

    python benchmarks/project_report.py [--workers 2]

Inputs, all found in the repository: the campaigns' packed runs (`campaign/*`, Fig. 3 and the
stage table), the arena records of the shipped policies (`docs/report/records/<policy>/*.jsonl.gz`,
Tables 2 and 3 and Fig. 4), the ladder if one has been built in `docs/report/ladder` (its
command: docs/commands.md) and, for Fig. 5 and the game a person can watch, replays this script
plays itself: each of `FIG5_TEAMS` against each of `FIG5_OPPONENTS`, `FIG5_GAMES` games (the
paper's 50), seats balanced, seed 0. Replays are regenerated each time (about a minute) into
`build/report_replays/` and not committed: same policies and seed, same games. A campaign still
training is drawn as far as it has logged. Not part of CI.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from rllib_pommer.arena.ladder import LADDER_FILE
from rllib_pommer.arena.records import RECORDS_SUFFIX
from rllib_pommer.evaluate import main as evaluate
from rllib_pommer.report import main as report

REPO = Path(__file__).resolve().parents[1]
REPORT = Path("docs/report")
LADDER = REPORT / "ladder"
REPLAYS = Path("build/report_replays")
FIG5_TEAMS = ("ppo", "ppo_cautious", "ppo_team", "ppo_dual_clip", "ppo_league")
FIG5_OPPONENTS = ("simple", "simple_nobomb", "static")  # the first game of the first is shown
FIG5_GAMES = 50


def play_replays(workers: int) -> list[Path]:
    """The Fig. 5 replay files, one per team and opponent, played afresh."""
    REPLAYS.mkdir(parents=True, exist_ok=True)
    files = []
    for team in FIG5_TEAMS:
        for opponent in FIG5_OPPONENTS:
            path = REPLAYS / f"{team}_vs_{opponent}.jsonl.gz"
            code = evaluate(["--team", team, "--vs", opponent, "--games", str(FIG5_GAMES),
                             "--seed", "0", "--workers", str(workers),
                             "--record", str(FIG5_GAMES), "--replays", str(path), "--force"])
            if code != 0:
                raise SystemExit(f"evaluate {team} vs {opponent} failed (exit {code})")
            files.append(path)
    return files


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--workers", type=int, default=2, help="arena processes")
    args = parser.parse_args(argv)
    os.chdir(REPO)  # the report names its inputs relative to the repository
    runs = sorted(path for path in Path("campaign").iterdir() if path.is_dir())
    records = sorted((REPORT / "records").glob(f"*/*{RECORDS_SUFFIX}"))
    if not runs or not records:
        raise SystemExit(f"{REPO}: needs campaign/* and {REPORT}/records/*/*{RECORDS_SUFFIX}")
    ladders = [LADDER] if (LADDER / LADDER_FILE).is_file() else []
    inputs = [*runs, *records, *ladders, *play_replays(args.workers)]
    code = report([*map(str, inputs), "--out", str(REPORT)])
    print(f"from {len(runs)} run(s) and {len(records)} record file(s)")
    return code


if __name__ == "__main__":
    sys.exit(main())
