"""`python -m rllib_pommer.ladder --out DIR [--policies a,b,c] [--games N] [--seed S]`: a ladder.

Plays every pair of the policies (default: every policy in policies/ that plays here, and each
learned one also with both filters, `_jitter_action`) for N games (even: seats balanced), and rates
them: DIR/ladder.md (the table: rating, 95% interval, games, wins / losses / ties), DIR/ladder.json
(the same and each pair's results) and DIR/ladder.png (ratings with their intervals), and a second
view, the same games fitted over the policies that play without the paper's filters only
(DIR/ladder_no_filters.json and .png, its table in ladder.md), so that no place comes from a
filtered variant of one agent. Each pair's games are kept as arena records,
DIR/records/<a>__vs__<b>.jsonl.gz, as soon as its match ends, and DIR/records/played.json keeps N,
the seed and a digest of each policy's file and weights. Running the command again resumes: pairs
played with the same N and seed are kept and a new policy plays only its new pairs; another N or
seed, a damaged pair file and the pairs of a policy changed since they were played are refused,
naming what. The model, the scale, the intervals and what is refused: rllib_pommer/arena/ladder.py.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tqdm import tqdm

from .arena.ladder import (
    BOOTSTRAP,
    LADDER_FILE,
    PLAIN_LADDER_FILE,
    Ladder,
    default_policies,
    rate,
    resume,
    save_pair,
    write_ladder,
)
from .arena.match import play_match
from .util.cli_options import non_negative_int, positive_int
from .util.errors import report_error
from .util.outputs import check_output_dir
from .viz.ladder import draw_ladders


def _names(text: str) -> tuple[str, ...]:
    names = tuple(name.strip() for name in text.split(",") if name.strip())
    if not names:
        raise argparse.ArgumentTypeError(f"names no policy (got {text!r}); leave --policies out "
                                         f"for the default ladder")
    return names


def play(ladder: Ladder, out: Path, workers: int | None) -> dict:
    """Every pair not yet in `out`, with progress on stderr; all pairs' records."""
    played = resume(ladder, out)  # refuses another ladder's pairs before any game
    todo = [pair for pair in ladder.pairs() if pair not in played]
    print(f"{len(ladder.pairs())} pairs of {len(ladder.policies)} policies: {len(played)} "
          f"played before, {len(todo)} to play ({len(todo) * ladder.games} games)")
    start = time.perf_counter()
    with tqdm(total=len(todo) * ladder.games, unit="game", file=sys.stderr, mininterval=1,
              disable=not todo) as bar:
        for pair in todo:
            bar.set_description(f"pair {len(played) + 1}/{len(ladder.pairs())} "
                                f"{pair[0]} vs {pair[1]}")
            played[pair] = play_match(ladder.match(pair), workers, bar.update)
            save_pair(out, pair, played[pair])
    if todo:
        seconds = time.perf_counter() - start
        print(f"played {len(todo)} pairs in {seconds:.0f} s "
              f"({len(todo) * ladder.games / seconds:.1f} games/s)")
    return played


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.ladder", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True, help="the ladder's folder")
    parser.add_argument("--policies", type=_names,
                        help="comma-separated policy names (default: every shipped and "
                             "scripted policy, learned ones also with _jitter_action)")
    parser.add_argument("--games", type=int, default=200,
                        help="games a pair, even (%(default)s)")
    parser.add_argument("--seed", type=non_negative_int, default=0,
                        help="every pair's match seed, and the bootstrap's (%(default)s)")
    parser.add_argument("--bootstrap", type=int, default=BOOTSTRAP,
                        help="replicates for the intervals (%(default)s)")
    parser.add_argument("--workers", type=positive_int, default=None,
                        help="processes (default: cores)")
    args = parser.parse_args(argv)
    try:
        check_output_dir(args.out, "--out")
        ladder = Ladder(args.policies or tuple(default_policies()), args.games, args.seed,
                        args.bootstrap)
        args.out.mkdir(parents=True, exist_ok=True)
        played = play(ladder, args.out, args.workers)
        write_ladder(args.out / LADDER_FILE, ladder, rate(ladder, played), played)
        plain = ladder.without_filters()
        if plain is not None:  # the second view: the same games, no filtered variants
            write_ladder(args.out / PLAIN_LADDER_FILE, plain, rate(plain, played), played)
        else:
            (args.out / PLAIN_LADDER_FILE).unlink(missing_ok=True)
        parts = list(draw_ladders(args.out, args.out))
        (args.out / "ladder.md").write_text("# Ladder\n\n" + "\n\n".join(parts) + "\n")
    except (ValueError, OSError) as exc:
        return report_error(exc)
    except KeyboardInterrupt:
        print(f"interrupted: the pairs finished are kept in {args.out}; run the same command "
              f"to resume", file=sys.stderr)
        return 130
    print("\n\n".join(part for part in parts if not part.startswith("![")))
    print(f"wrote {args.out / 'ladder.md'}, {LADDER_FILE} and ladder.png"
          + (f", {PLAIN_LADDER_FILE} and ladder_no_filters.png" if plain else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
