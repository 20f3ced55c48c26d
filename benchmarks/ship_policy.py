"""Ship a PPO run as a named policy, with its model card and the paper's table, in one command:

    python benchmarks/ship_policy.py --run campaign/paper --policy ppo [--games 1000] [--workers 1]

1. The run's newest checkpoint is exported to `policies/<policy>` (`train --export`). A policy
   already there (an interim export) is moved to `build/replaced/<policy>/` first, and its
   hand-written `NOTES.md` is carried into the new folder, since the notes outlive exports.
2. The paper's table is played for it (`paper_table.py`: every opponent row x filter column,
   `--games` per cell, seats balanced, seed 0) into `docs/report/records/<policy>/`; old records
   are moved aside the same way. Finished cells are kept, so an interrupted table resumes.
3. The model card is redrawn with those records (`report --card`).

Then `python benchmarks/project_report.py` redraws the report. Not part of CI: about an hour on
one core at 1000 games a cell.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import time
from pathlib import Path

from paper_table import main as play_table

from rllib_pommer.arena.records import RECORDS_SUFFIX
from rllib_pommer.report import main as report
from rllib_pommer.train import main as train

REPO = Path(__file__).resolve().parents[1]
NOTES = "NOTES.md"


def _move_aside(path: Path, stamp: str) -> Path | None:
    """`path` moved under build/replaced/ (None if it was not there)."""
    if not path.exists():
        return None
    aside = REPO / "build" / "replaced" / stamp / path
    aside.parent.mkdir(parents=True, exist_ok=True)
    shutil.move(path, aside)
    return aside


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--run", type=Path, required=True, help="a packed or stopped run folder")
    parser.add_argument("--policy", required=True, help="the name to ship it under")
    parser.add_argument("--games", type=int, default=1000, help="games per table cell")
    parser.add_argument("--workers", type=int, default=1, help="arena processes")
    parser.add_argument("--keep-records", action="store_true",
                        help="resume a table begun for this same export instead of replacing it")
    args = parser.parse_args(argv)
    run = args.run.resolve()
    os.chdir(REPO)  # the card names its policy and records relative to the repository
    policy = Path("policies") / args.policy
    records = Path("docs") / "report" / "records" / args.policy
    stamp = time.strftime("%Y%m%d-%H%M%S")

    old_policy = _move_aside(policy, stamp)
    _move_aside(policy.with_suffix(".toml"), stamp)
    if not args.keep_records:
        _move_aside(records, stamp)
    code = train(["--out", str(run), "--export", str(policy)])
    if code != 0:
        return code
    if old_policy is not None and (old_policy / NOTES).is_file():
        shutil.copy2(old_policy / NOTES, policy / NOTES)
    print(f"exported {args.run} -> {policy}" + (f" (previous one in {old_policy})"
                                                 if old_policy else ""), flush=True)
    code = play_table(["--team", args.policy, "--games", str(args.games), "--out", str(records),
                       "--workers", str(args.workers)])
    if code != 0:
        return code
    return report(["--card", str(policy),
                   *map(str, sorted(records.glob(f"*{RECORDS_SUFFIX}")))])


if __name__ == "__main__":
    sys.exit(main())
