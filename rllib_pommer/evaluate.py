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
(`--replays FILE`, .jsonl or .jsonl.gz, default arena_replays.jsonl.gz, with every agent's
observations if `--with-observations`; TeamRadio replays keep every agent's words), for
`python -m rllib_pommer.replay render|html|verify`.

The outputs are checked before the first game: a records file must end in .jsonl, .jsonl.gz or
.csv and a replays file in .jsonl or .jsonl.gz, the two may not be one file, `--replays` needs
`--record K`, and an existing file is replaced only with `--force`.
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
from .arena.records import RECORDS_SUFFIXES, summarise, write_records
from .game.records import JSONL_SUFFIXES, write_games
from .util.cli_options import non_negative_int, positive_int
from .util.errors import report_error
from .util.outputs import check_distinct, check_output

DEFAULT_REPLAYS = Path("arena_replays.jsonl.gz")


def _filters(text: str) -> tuple[str, ...]:
    names = tuple(n for n in text.split(",") if n)
    unknown = [n for n in names if n not in FILTERS]
    if unknown:
        raise argparse.ArgumentTypeError(f"unknown filter {unknown[0]!r}; valid: {list(FILTERS)}")
    return names


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


def _check_outputs(args: argparse.Namespace) -> Path | None:
    """Refuse bad outputs before any game (module docstring); the replays file, if any."""
    if args.replays and not args.record:
        raise ValueError(f"--replays {args.replays} is written only with --record K, the number "
                         f"of games to keep as replays")
    replays = (args.replays or DEFAULT_REPLAYS) if args.record else None
    check_output(args.records, "--records", args.force, RECORDS_SUFFIXES)
    check_output(replays, "--replays", args.force, JSONL_SUFFIXES)
    check_distinct({"--records": args.records, "--replays": replays})
    return replays


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.evaluate", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--team", required=True, help="policy name or file of team A")
    parser.add_argument("--vs", required=True, help="policy name or file of team B")
    parser.add_argument("--games", type=positive_int, default=100)
    parser.add_argument("--filters", type=_filters, default=(), help="e.g. jitter,action")
    parser.add_argument("--seed", type=non_negative_int, default=0)
    parser.add_argument("--fixed-seats", action="store_true", help="team A always on {0, 2}")
    parser.add_argument("--variant", choices=("team", "radio"), default="team",
                        help="the game: Team, or TeamRadio with words (default: %(default)s)")
    parser.add_argument("--workers", type=positive_int, default=None,
                        help="processes (default: cores)")
    parser.add_argument("--records", type=Path, help="per-game rows, .jsonl, .jsonl.gz or .csv")
    parser.add_argument("--record", type=non_negative_int, default=0, metavar="K",
                        help="write the first K games as replays")
    parser.add_argument("--replays", type=Path,
                        help=f"where --record writes, .jsonl or .jsonl.gz (default: "
                             f"{DEFAULT_REPLAYS})")
    parser.add_argument("--with-observations", action="store_true",
                        help="replays include every agent's observations")
    parser.add_argument("--json", action="store_true", help="print a final JSON summary")
    parser.add_argument("--force", action="store_true",
                        help="replace existing --records and --replays files")
    args = parser.parse_args(argv)
    try:
        replays = _check_outputs(args)
        spec = MatchSpec(args.team, args.vs, args.games, args.seed, args.filters, args.fixed_seats,
                         args.variant)
        start = time.perf_counter()
        with tqdm(total=spec.games, unit="game", file=sys.stderr, mininterval=1) as bar:
            records = play_match(spec, args.workers, bar.update)
        elapsed = time.perf_counter() - start
    except ValueError as exc:
        return report_error(exc)
    summary = summarise(records)
    summary["seconds"] = elapsed
    print(format_summary(spec, summary))  # first: the match's result survives a failed write
    print(f"  {len(records) / elapsed:.1f} games/s")
    failed = 0
    try:
        if args.records:
            write_records(args.records, records)
        if replays:
            count = write_games(replays,
                                record_games(spec, args.record, args.with_observations))
            print(f"  wrote {count} replays to {replays}")
    except OSError as exc:
        failed = report_error(f"the match was played, but writing its output failed: {exc}")
    if args.json:
        print(json.dumps({"team": spec.team, "vs": spec.vs, "filters": list(spec.filters),
                          "seed": spec.seed, "variant": spec.variant, **summary}))
    return failed


if __name__ == "__main__":
    sys.exit(main())
