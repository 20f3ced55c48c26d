"""What an expert does standing on a bomb, by the bomb's life: the share of its moves that stay
(Stop) and that step off, in an expert dataset (issue 51's imitation comparison).

    python benchmarks/bomb_waits.py runs/expert_clones/data_simple runs/expert_clones/data_search

SimpleAgent steps off the bomb it has just laid; the search agent often waits on it and leaves
late, once its planned escape needs the time. A clone sees the bomb's life but not the plan, so
the waiting is what it copies. Prints one table per dataset (rows: life 9 to 1, the samples
standing on a bomb of that life, the share of Stop, of a move, and of Bomb).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from rllib_pommer.data.dataset import open_dataset
from rllib_pommer.game.constants import Action

LIVES = range(9, 0, -1)


def waits(data_dir: str) -> np.ndarray:
    """counts[life, action]: the samples of `data_dir` whose agent stands on a bomb of that life,
    by the action taken."""
    counts = np.zeros((max(LIVES) + 1, len(Action)), np.int64)
    for batch in open_dataset(data_dir).iter_batches(65_536, shuffle=False):
        rows = np.arange(len(batch.action))
        row, col = batch.obs.position[:, 0], batch.obs.position[:, 1]
        life = batch.obs.bomb_life[rows, row, col]
        np.add.at(counts, (life, batch.action), 1)
    return counts


def table(name: str, counts: np.ndarray) -> str:
    moves = [int(a) for a in (Action.UP, Action.DOWN, Action.LEFT, Action.RIGHT)]
    lines = [f"{name}", "| life | samples | stop | move | bomb |", "|---:|---:|---:|---:|---:|"]
    for life in LIVES:
        n = counts[life].sum()
        if n:
            lines.append(f"| {life} | {n:,} | {counts[life, Action.STOP] / n:.2f} | "
                         f"{counts[life, moves].sum() / n:.2f} | "
                         f"{counts[life, Action.BOMB] / n:.2f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("data_dirs", nargs="+", help="expert dataset folders (collect --out)")
    args = parser.parse_args(argv)
    for data_dir in args.data_dirs:
        try:
            print(table(data_dir, waits(data_dir)), end="\n\n")
        except ValueError as error:
            print(f"bomb_waits: {error}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
