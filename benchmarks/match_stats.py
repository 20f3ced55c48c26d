"""SimpleAgent match statistics beside the reference's (tests/reference/simpleagent_stats.json).

    python benchmarks/match_stats.py [--games 1000] [--seed 0]

SimpleAgent on seats {0, 2} against SimpleAgent, StaticAgent and SimpleAgent_NoBomb, as in the
reference protocol (docs/measurements.md, SimpleAgent match statistics). For each statistic it
prints ours, the reference's value and 95% interval, and whether ours falls inside it. Exit 1 if
any does not. Not part of CI (minutes).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from tqdm import tqdm

from rllib_pommer.arena.match import MatchSpec, play_match
from rllib_pommer.arena.records import summarise

REFERENCE = Path(__file__).resolve().parents[1] / "tests" / "reference" / "simpleagent_stats.json"
CONFIGS = {"vs_SimpleAgent": "simple", "vs_StaticAgent": "static",
           "vs_SimpleAgent_NoBomb": "simple_nobomb"}
# our summary key -> (reference value key, reference interval key)
STATISTICS = {
    "win": ("teamA_win_rate", "teamA_win_rate_ci95"),
    "loss": ("teamA_loss_rate", "teamA_loss_rate_ci95"),
    "tie": ("teamA_tie_rate", "teamA_tie_rate_ci95"),
    "mean_length": ("game_length_mean", "game_length_mean_ci95"),
    "bombs_per_agent_a": ("bombs_per_teamA_agent_per_game_mean",
                          "bombs_per_teamA_agent_per_game_ci95"),
    "games_with_own_bomb_death_a": ("frac_games_teamA_agent_died_by_own_bomb",
                                    "frac_games_teamA_agent_died_by_own_bomb_ci95"),
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--games", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, help="also write the comparison here")
    args = parser.parse_args()
    reference = json.loads(REFERENCE.read_text())
    outside, rows = 0, []
    for config, opponent in CONFIGS.items():
        spec = MatchSpec("simple", opponent, args.games, args.seed, fixed_seats=True)
        with tqdm(total=spec.games, desc=config, unit="game", file=sys.stderr) as bar:
            summary = summarise(play_match(spec, progress=bar.update))
        for ours_key, (ref_key, ci_key) in STATISTICS.items():
            lo, hi = reference[config][ci_key]
            inside = lo <= summary[ours_key] <= hi
            outside += not inside
            rows.append({"config": config, "statistic": ours_key, "ours": summary[ours_key],
                         "reference": reference[config][ref_key], "ci95": [lo, hi],
                         "inside": inside})
            print(f"{config:24s} {ours_key:28s} ours {summary[ours_key]:8.3f}   reference "
                  f"{reference[config][ref_key]:8.3f} [{lo:.3f}, {hi:.3f}]   "
                  f"{'inside' if inside else 'OUTSIDE'}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    print(f"{len(rows) - outside} of {len(rows)} statistics inside the reference's 95% intervals")
    return 1 if outside else 0


if __name__ == "__main__":
    sys.exit(main())
