"""`python -m rllib_pommer.report RUN_OR_RECORDS... --out DIR`: our runs in the paper's figures
and tables, as DIR/report.md with PNGs beside it.

Each input is classified by its content:

- a directory: the Tune trial directories in or below it (progress.csv or result.json) give
  Fig. 3, the training reward per curriculum phase (columns: rllib_pommer/runs/history.py);
- a .jsonl, .jsonl.gz or .csv file of arena rows (`evaluate --records`, whose rows name their
  match; older files: a sidecar .json or the file name, see rllib_pommer/viz/matches.py) gives
  the win/loss/tie tables, with 95% intervals, in the layout of the paper's Tables 2 and 3
  beside the paper's numbers, and Fig. 4, the effect of the filters;
- a .jsonl[.gz] file of game replays (`evaluate --record K`) gives Fig. 5, the position and bomb
  heatmaps per opponent, and a picture and a viewer of its first game;
- a ladder's folder (`python -m rllib_pommer.ladder --out DIR`, holding ladder.json) gives the
  ladder: each policy's rating with its interval, as a plot and a table.

`--card POLICY_DIR` instead redraws the model card of a policy that `train --export` shipped
(POLICY_DIR/MODEL_CARD.md: its training from the folder itself, the results tables and Fig. 4
from the record files given).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .runs.history import exported_training, run_training
from .util.errors import report_error
from .viz.model_card import write_model_card
from .viz.report import SUMMARIES, classify, write_report


def _records(paths: list[Path]) -> list[Path]:
    found = classify(paths)
    if any(paths for kind, paths in found.items() if kind != "records"):
        raise ValueError("--card takes arena record files only (its training comes from the "
                         "policy folder)")
    return found["records"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.report", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("inputs", nargs="*", type=Path,
                        help="Tune run directories, arena record files, replay files")
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--out", type=Path, help="directory for report.md + PNGs")
    where.add_argument("--card", type=Path, metavar="POLICY_DIR",
                       help="redraw this exported policy's MODEL_CARD.md; inputs: record files")
    args = parser.parse_args(argv)
    if args.out and not args.inputs:
        parser.error("--out needs inputs")
    try:
        if args.card:
            records = _records(args.inputs)  # the inputs first: the folder may not be a card's
            report = write_model_card(args.card, *exported_training(args.card), records)
        else:
            found = classify(args.inputs)
            training = (run_training(found["runs"], args.out / SUMMARIES)
                        if found["runs"] else None)
            report = write_report(args.out, found, training)
    except (ValueError, OSError) as exc:
        return report_error(exc)
    print(f"wrote {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
