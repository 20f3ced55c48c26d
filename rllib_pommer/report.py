"""`python -m rllib_pommer.report RUN_OR_RECORDS... --out DIR`: our runs in the paper's figures
and tables, as DIR/report.md with PNGs beside it.

Each input is classified by its content:

- a directory: the Tune trial directories in or below it (progress.csv or result.json) give
  Fig. 3, the training reward per curriculum phase (columns: rllib_pommer/viz/training.py);
- a .jsonl or .csv file of arena rows (`evaluate --records`, whose rows name their match; older
  files: a sidecar .json or the file name, see rllib_pommer/viz/matches.py) gives the
  win/loss/tie tables, with 95% intervals, in
  the layout of the paper's Tables 2 and 3 beside the paper's numbers, and Fig. 4, the effect of
  the filters;
- a .jsonl[.gz] file of game replays (`evaluate --record K`) gives Fig. 5, the position and bomb
  heatmaps per opponent, and a picture and a viewer of its first game.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .viz.report import write_report


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.report", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("inputs", nargs="+", type=Path,
                        help="Tune run directories, arena record files, replay files")
    parser.add_argument("--out", type=Path, required=True, help="directory for report.md + PNGs")
    args = parser.parse_args(argv)
    try:
        report = write_report(args.inputs, args.out)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
