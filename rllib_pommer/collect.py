"""`python -m rllib_pommer.collect --games N --out DIR`: the expert dataset for imitation.

Plays N 2v2 Team games of four SimpleAgents (as in Meisheri et al. 2019) on all cores and writes
every living agent's raw observation and action (and with --label-draws K, SimpleAgent's action
counts over K tie-breaking draws), one row per (game, step, agent), to Parquet
shards DIR/shard-NNNNNN.parquet of --shard-games games each (schema: rllib_pommer/data/schema.py;
read them with rllib_pommer.data.dataset.open_dataset). Same --seed, same dataset, whatever
--workers. Re-running the same command resumes: finished shards are kept, the rest are played.

With --expert search (or search_fast, or any policy file of kind search), four search agents
at the file's effort play instead (docs/search.md), seated and seeded as in the arena, and each
row's action is the one its agent played: the same rows and planes, so `imitate` trains on them
unchanged. The search agent's only randomness is its draw between actions whose values lie
within 1 of each other; with --label-draws K each row also counts the actions K further draws
pick from the same values (no further search, so nearly free). Search games are slow
(docs/measurements.md), so their shards default to 16 games. The shards name their expert and
its effort, and a directory holding another expert's shards is refused.

With --dagger POLICY, the learned policy plays instead (its team on seats {0, 2} and {1, 3} in
turn, against the --vs opponents in turn) and only its decisions are recorded, each labelled with
what SimpleAgent would have done there (rllib_pommer/data/dagger.py).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tqdm import tqdm

from .data.collector import SEARCH_SHARD_GAMES, SHARD_GAMES, Collection, Dagger, ShardResult
from .util.cli_options import positive_int
from .util.errors import report_error
from .util.outputs import check_output_dir


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.collect", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--games", type=positive_int, required=True)
    parser.add_argument("--out", type=Path, required=True, help="dataset directory")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=positive_int, default=None,
                        help="processes (default: cores)")
    parser.add_argument("--shard-games", type=positive_int, default=None,
                        help=f"games per shard (default: {SHARD_GAMES}; {SEARCH_SHARD_GAMES} "
                             "with a search expert)")
    parser.add_argument("--expert", default="simple",
                        help="who plays all four seats: simple, or a policy of kind search "
                             "(search, search_fast, a .toml file) (default: %(default)s)")
    parser.add_argument("--label-draws", type=int, default=0, metavar="K",
                        help="also record the expert's action counts over K draws from the same "
                             "memory per decision, the soft targets of imitation (0..255)")
    parser.add_argument("--dagger", metavar="POLICY",
                        help="DAgger data: this learned policy plays (greedy) and SimpleAgent "
                             "labels the states it visits (needs --label-draws)")
    parser.add_argument("--vs", default="simple,static",
                        help="DAgger opponents, comma-separated, taken in turn (default: "
                             "%(default)s)")
    args = parser.parse_args(argv)
    dagger = None
    if args.dagger:
        from .imitation.learned import greedy_actor  # torch, for DAgger only

        dagger = Dagger(args.dagger, tuple(args.vs.split(",")), greedy_actor)
    shard_games = args.shard_games or (SHARD_GAMES if args.expert == "simple"
                                       else SEARCH_SHARD_GAMES)
    try:
        check_output_dir(args.out, "--out")
        collection = Collection(args.out, args.games, args.seed, shard_games,
                                args.label_draws, dagger, args.expert)
    except ValueError as exc:
        return report_error(exc)
    resumed = sum(r.games for r in collection.results.values())
    resumed_samples = samples = sum(r.samples for r in collection.results.values())
    start = time.perf_counter()
    expert = collection.plan.template.expert
    with tqdm(total=args.games, initial=resumed, unit="game", file=sys.stderr, smoothing=0.1,
              desc=None if args.expert == "simple" else expert) as bar:
        bar.set_postfix(samples=samples)

        def progress(result: ShardResult) -> None:
            nonlocal samples
            samples += result.samples
            bar.set_postfix(samples=samples, refresh=False)
            bar.update(result.games)

        results = collection.run(args.workers, progress)
    elapsed = time.perf_counter() - start
    played, new_samples = args.games - resumed, samples - resumed_samples
    total_bytes = sum(r.bytes for r in results.values())
    print(f"{args.out}: {len(results)} shards, {args.games} games, {samples} samples, "
          f"{total_bytes / 2**20:.1f} MiB ({total_bytes / max(samples, 1):.1f} bytes/sample)")
    print(f"played {played} games in {elapsed:.1f} s: {played / elapsed:.1f} games/s, "
          f"{new_samples / elapsed:.0f} samples/s"
          + (f" (resumed after {resumed})" if resumed else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
