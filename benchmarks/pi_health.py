"""pi's health through the campaigns: logit spread and PPO's log-ratio extremes against games.

    python benchmarks/pi_health.py [--out docs/report/pi_health.png]

One line per run: the committed campaigns (`campaign/*`, as far as they have logged) and the
paper campaign's run with pi in bfloat16 that collapsed from about 93,000 games, whose rows are
read from the commit that keeps it (`COLLAPSED`). Each point is the median over
`WINDOW` iterations of the learner's per-iteration figures (`rl/learner.py`): the largest
batch-mean logit spread, and the largest |log-ratio| of any row PPO trained on (past 88 PPO's
float32 ratio overflows). Iterations with pi frozen (the value warm-ups) log a log-ratio of 0
and are left out of the lower panel. Not part of CI; needs git for the collapsed run.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from rllib_pommer.runs.history import find_trials, number, read_trial  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
COLLAPSED = ("57c1c4d", "campaign/paper/PPO_pommerman_team_2991b_00000_0_2026-12-01_18-58-15/"
             "history.csv", "paper, pi in bfloat16 (collapsed)")
WINDOW = 25
# Games played before a run began, for a run that continues another (its curriculum's
# pi_weights and vf_weights): drawn from where it took over.
CONTINUES = {"paper_dual_clip": 83_562}
LABELS = {"paper": "paper, pi in float32 from 83,562 games",
          "paper_dual_clip": "paper_dual_clip (dual clip 3, from paper at 83,562)"}
EPISODES = "env_runners/num_episodes_lifetime"
SPREAD = "learners/learner/pi_logit_spread"
RATIO = ("learners/learner/pi_log_ratio_max", "learners/learner/pi_log_ratio_min")


def series(rows: list[dict], offset: int = 0) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{panel: (games, rolling median)} of one run's rows, `offset` games after the start."""
    games = np.array([number(row.get(EPISODES)) for row in rows]) + offset
    spread = np.array([number(row.get(SPREAD)) for row in rows])
    ratio = np.array([max(abs(number(row.get(RATIO[0]))), abs(number(row.get(RATIO[1]))))
                      for row in rows])
    ratio[ratio == 0] = np.nan  # pi frozen
    out = {}
    for panel, values in (("spread", spread), ("ratio", ratio)):
        keep = np.isfinite(values) & np.isfinite(games)
        if keep.sum() >= WINDOW:
            windows = np.lib.stride_tricks.sliding_window_view(values[keep], WINDOW)
            out[panel] = games[keep][WINDOW - 1:], np.median(windows, axis=1)
    return out


def collapsed_rows() -> list[dict]:
    commit, path, _ = COLLAPSED
    text = subprocess.run(["git", "-C", str(REPO), "show", f"{commit}:{path}"], check=True,
                          capture_output=True, text=True).stdout
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "history.csv").write_text(text)
        return read_trial(Path(folder)).rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=REPO / "docs/report/pi_health.png")
    args = parser.parse_args(argv)
    runs = {COLLAPSED[2]: collapsed_rows()}
    for run in sorted(path for path in (REPO / "campaign").iterdir() if path.is_dir()):
        for trial in find_trials(run):
            runs[run.name] = read_trial(trial).rows
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    for name, rows in runs.items():
        lines = series(rows, CONTINUES.get(name, 0))
        style = {"linestyle": ":"} if name == COLLAPSED[2] else {}
        for axis, panel in ((top, "spread"), (bottom, "ratio")):
            if panel in lines:
                axis.plot(*lines[panel], label=LABELS.get(name, name), linewidth=1.2, **style)
    top.set(yscale="log", ylabel="pi's logit spread (largest batch mean)",
            title=f"pi's health per run (medians of {WINDOW} iterations)")
    bottom.set(yscale="log", ylabel="largest |log-ratio| PPO trained on",
               xlabel="games (lifetime episodes)")
    bottom.axhline(88, color="grey", linewidth=0.8, linestyle="--")
    bottom.annotate("float32 ratio overflows", (0, 88), textcoords="offset points",
                    xytext=(4, 4), fontsize=8, color="grey")
    top.legend(fontsize=8)
    figure.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.out, dpi=110)
    print(f"wrote {args.out} ({', '.join(runs)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
