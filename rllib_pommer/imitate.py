"""`python -m rllib_pommer.imitate --data DIR --out policies/imitation`: behaviour cloning.

Trains the paper's CNN on a dataset made by `python -m rllib_pommer.collect`, then writes into OUT
the policy weights (`pi.pt`, a plain state_dict) and `metrics.json`, and beside OUT a policy file
`<OUT name>.toml` (kind "learned") so the arena, training and serving find the policy by name.
Training state and TensorBoard logs go to OUT/training/; re-running the same command resumes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .bc import WEIGHTS_FILE, BCConfig, train


def write_policy_file(out: Path, description: str) -> Path:
    policy = out.parent / f"{out.name}.toml"
    policy.write_text(f'kind = "learned"\nweights = "{out.name}/{WEIGHTS_FILE}"\n'
                      f'description = "{description}"\n')
    return policy


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.imitate", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, required=True, help="dataset folder of shards")
    parser.add_argument("--out", type=Path, required=True, help="policy folder to write")
    parser.add_argument("--epochs", type=int, default=1)
    parser.add_argument("--batch-size", type=int, default=512)
    parser.add_argument("--lr", type=float, default=1e-3)
    parser.add_argument("--dropout", type=float, default=0.2)
    parser.add_argument("--val-fraction", type=float, default=0.05)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--threads", type=int, default=2, help="torch threads")
    parser.add_argument("--max-batches-per-epoch", type=int, default=None)
    args = parser.parse_args(argv)
    cfg = BCConfig(data=args.data, out=args.out, epochs=args.epochs, batch_size=args.batch_size,
                   lr=args.lr, dropout=args.dropout, val_fraction=args.val_fraction,
                   seed=args.seed, threads=args.threads,
                   max_batches_per_epoch=args.max_batches_per_epoch)
    try:
        metrics = train(cfg)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    policy = write_policy_file(args.out, f"Behaviour cloning of SimpleAgent ({args.data.name})")
    print(f"validation accuracy {metrics['validation_accuracy']:.4f}, "
          f"loss {metrics['validation_loss']:.4f}; weights {args.out / WEIGHTS_FILE}, "
          f"policy file {policy}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
