"""How the league curriculum's PPO scales on this machine: `bench scale` with its figure.

    python benchmarks/scale.py --out docs/report/scale [--iterations 2]

Runs every layout of `rllib_pommer.launch.scale.LAYOUTS` side by side in one Ray instance (run it
on an otherwise idle machine) and writes OUT/scale.json (the figures), OUT/scale.md (the table
docs/measurements.md shows) and OUT/scale.png: each layout's whole-loop env steps/s and learner
samples/s as multiples of the default layout's. Not part of CI (minutes).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from rllib_pommer.launch.scale import scale_speeds, scale_table  # noqa: E402


def draw(result: dict, path: Path) -> None:
    """Horizontal bars: each layout's loop and learner rates over the default layout's."""
    rows = result["layouts"]
    names = [row["name"] for row in rows]
    y = range(len(rows))
    fig, ax = plt.subplots(figsize=(8, 0.5 * len(rows) + 1.5))
    ax.barh([i - 0.2 for i in y], [row["env_steps_ratio"] for row in rows], height=0.4,
            label="whole loop, env steps/s")
    ax.barh([i + 0.2 for i in y], [row["learner_ratio"] for row in rows], height=0.4,
            label="learner alone, samples/s")
    ax.axvline(1.0, color="grey", linewidth=0.8)
    ax.set_yticks(list(y), names)
    ax.invert_yaxis()
    ax.set_xlabel("x the default layout (local learner, 1 thread)")
    ax.set_title(f"PPO on {result['cores']} cores, {result['curriculum']} curriculum")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.3), ncol=2, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True, help="folder for the three files")
    parser.add_argument("--iterations", type=int, default=2, help="timed iterations a layout")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    result = scale_speeds(iterations=args.iterations)
    (args.out / "scale.json").write_text(json.dumps(result, indent=1) + "\n")
    (args.out / "scale.md").write_text(scale_table(result) + "\n")
    draw(result, args.out / "scale.png")
    print(scale_table(result))
    print(f"best: {result['best']} ({result['best_command']}); wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
