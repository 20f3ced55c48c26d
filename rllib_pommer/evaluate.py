"""`python -m rllib_pommer.evaluate --team A --vs B --games N`: the arena.

Plays N Team games (`--variant radio`: TeamRadio, where policies named with the `_words` suffix and
learned radio networks send words) of policy A against policy B on all cores, half of them with A on
seats {0, 2} and half on {1, 3} (`--fixed-seats`: always {0, 2}), and prints A's win/loss/tie rates
with 95% Wilson intervals, the mean game length, A's agents lost to their own bombs, and per game
who killed whom (each team's kills, suicides and team kills: `game/kills.py`). `--records FILE`
writes one row per game (.jsonl, gzipped .jsonl.gz, or .csv) with the columns

    game, seed, seats_a, result (win/loss/tie for A), length, died, own_bomb_deaths, bombs_laid,
    team, vs, filters, killers, variant

(died, own_bomb_deaths, bombs_laid and killers by seat 0..3; team, vs and filters name the match,
so `python -m rllib_pommer.report` reads the file alone), from which every table can be
recomputed.
Same seed, same records.
`--record K` also writes the first K games as replays in the reference's JSON Lines schema
(`--replays FILE`, with every agent's observations if `--with-observations`; TeamRadio replays
keep every agent's words), for `python -m rllib_pommer.replay render|html|verify`.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from tqdm import tqdm

from .agents.registry import FILTERS
from .arena.match import MatchSpec, play_match, record_games
from .arena.records import summarise, write_records
from .game.records import write_games
from .util.outputs import check_output


def _filters(text: str) -> tuple[str, ...]:
    names = tuple(n for n in text.split(",") if n)
    unknown = [n for n in names if n not in FILTERS]
    if unknown:
        raise argparse.ArgumentTypeError(f"unknown filter {unknown[0]!r}; valid: {list(FILTERS)}")
    return names


def _positive(text: str) -> int:
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive number of games, got {value}")
    return value


def format_summary(spec: MatchSpec, summary: dict) -> str:
    def rate(key):
        lo, hi = summary[f"{key}_ci95"]
        return f"{summary[key]:.3f} [{lo:.3f}, {hi:.3f}]"

    return "\n".join([
        f"{spec.team}{'+' + '+'.join(spec.filters) if spec.filters else ''} vs {spec.vs}: "
        f"{summary['games']} {'TeamRadio ' if spec.variant == 'radio' else ''}games, "
        f"seed {spec.seed}",
        f"  win  {rate('win')}",
        f"  loss {rate('loss')}",
        f"  tie  {rate('tie')}",
        f"  mean length {summary['mean_length']:.1f}; "
        f"agents lost to their own bombs {summary['own_bomb_deaths_a']}; "
        f"bombs per agent {summary['bombs_per_agent_a']:.2f} vs {summary['bombs_per_agent_b']:.2f}",
        "  per game, ours vs theirs: " + "; ".join(
            f"{label} {summary[f'{key}_a_per_game']:.2f} vs {summary[f'{key}_b_per_game']:.2f}"
            for label, key in (("kills", "kills"), ("suicides", "suicides"),
                               ("team kills", "team_kills"))),
    ])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.evaluate", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--team", required=True, help="policy name or file of team A")
    parser.add_argument("--vs", required=True, help="policy name or file of team B")
    parser.add_argument("--games", type=_positive, default=100)
    parser.add_argument("--filters", type=_filters, default=(), help="e.g. jitter,action")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--fixed-seats", action="store_true", help="team A always on {0, 2}")
    parser.add_argument("--variant", choices=("team", "radio"), default="team",
                        help="the game: Team, or TeamRadio with words (default: %(default)s)")
    parser.add_argument("--workers", type=int, default=None, help="processes (default: cores)")
    parser.add_argument("--records", type=Path, help="per-game rows, .jsonl, .jsonl.gz or .csv")
    parser.add_argument("--record", type=int, default=0, metavar="K",
                        help="write the first K games as replays")
    parser.add_argument("--replays", type=Path, default=Path("arena_replays.jsonl.gz"),
                        help="where --record writes (default: %(default)s)")
    parser.add_argument("--with-observations", action="store_true",
                        help="replays include every agent's observations")
    parser.add_argument("--json", action="store_true", help="print a final JSON summary")
    args = parser.parse_args(argv)
    try:
        check_output(args.records, "--records")
        check_output(args.replays if args.record > 0 else None, "--replays")
        spec = MatchSpec(args.team, args.vs, args.games, args.seed, args.filters, args.fixed_seats,
                         args.variant)
        start = time.perf_counter()
        with tqdm(total=spec.games, unit="game", file=sys.stderr, mininterval=1) as bar:
            records = play_match(spec, args.workers, bar.update)
        elapsed = time.perf_counter() - start
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    summary = summarise(records)
    summary["seconds"] = elapsed
    print(format_summary(spec, summary))  # first: the match's result survives a failed write
    print(f"  {len(records) / elapsed:.1f} games/s")
    failed = 0
    try:
        if args.records:
            write_records(args.records, records)
        if args.record > 0:
            count = write_games(args.replays,
                                record_games(spec, args.record, args.with_observations))
            print(f"  wrote {count} replays to {args.replays}")
    except OSError as exc:
        print(f"error: the match was played, but writing its output failed: {exc}",
              file=sys.stderr)
        failed = 2
    if args.json:
        print(json.dumps({"team": spec.team, "vs": spec.vs, "filters": list(spec.filters),
                          "seed": spec.seed, "variant": spec.variant, **summary}))
    return failed


if __name__ == "__main__":
    sys.exit(main())
