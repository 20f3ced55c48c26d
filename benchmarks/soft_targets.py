"""What the number of label draws K buys: behaviour cloning accuracy against collection cost.

    python benchmarks/soft_targets.py --data DATASET --batches 4000 [--draws 0 1 4 16]

DATASET must have been collected with at least max(--draws) label draws (`collect
--label-draws`). Each K trains the same network from the same seed on the same stream of batches
for --batches batches; the targets use K of each sample's recorded draws (drawn without
replacement, as a collection with K draws would have recorded; K = 0 is the one-hot recorded
action alone). All runs are scored on the same held-out games against the full recorded
distribution. Collection cost is measured side by side: SimpleAgent games per second on this
core with K draws per decision. Not part of CI.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from rllib_pommer.data.expert import play_games
from rllib_pommer.imitation.bc import BCConfig, train


def collection_games_per_s(draws: int, games: int = 32) -> float:
    play_games(1, range(2), label_draws=draws)  # compile
    start = time.perf_counter()
    play_games(1, range(games), label_draws=draws)
    return games / (time.perf_counter() - start)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, required=True)
    parser.add_argument("--batches", type=int, default=4000)
    parser.add_argument("--draws", type=int, nargs="+", default=[0, 1, 4, 16])
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for draws in args.draws:
            cfg = BCConfig(data=[args.data], out=Path(tmp) / f"k{draws}", threads=args.threads,
                           max_batches_per_epoch=args.batches, max_label_draws=draws,
                           val_fraction=0.02, max_val_batches=200)
            metrics = train(cfg)
            rows.append({"draws": draws, "collection_games_per_s": collection_games_per_s(draws),
                         "train_samples": args.batches * cfg.batch_size,
                         **{k: metrics[f"validation_{k}"] for k in (
                             "accuracy", "mode_accuracy", "expected_agreement", "loss")}})
            print(json.dumps(rows[-1]), flush=True)
    print("| K | collection games/s (one core) | accuracy (recorded action) | mode accuracy | "
          "expected agreement |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['draws']} | {r['collection_games_per_s']:.1f} | {r['accuracy']:.4f} | "
              f"{r['mode_accuracy']:.4f} | {r['expected_agreement']:.4f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
