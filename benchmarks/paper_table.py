"""Play one of the paper's result tables for a team: every opponent row x filter column.

    python benchmarks/paper_table.py --team imitation --games 1000 --out runs/table2
    python -m rllib_pommer.report runs/table2/*.jsonl.gz --out runs/table2/report

Each cell is an arena match with seats balanced, written as
`<team>[+filters]__vs__<opponent>.jsonl.gz` plus the `--json` summary beside it (`.json`), the
layout `rllib_pommer.report` reads to print the table next to the paper's numbers. Finished cells
are skipped, so an interrupted run resumes; a cell whose records file holds fewer games than its
summary (empty, cut short) is played again, and a folder holding cells of other `--games` or
`--seed` is refused (its numbers are not this command's).
Opponents default to the rows of the paper's table for the team (`imitation`: Table 2, `ppo`:
Table 3) that name a policy we have (never Skynet), else to the
scripted rows of Table 2. Not part of CI (about a minute per 1000-game cell).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from rllib_pommer.agents.registry import resolve_policy
from rllib_pommer.arena.records import RECORDS_SUFFIX, read_rows
from rllib_pommer.evaluate import main as evaluate
from rllib_pommer.util.outputs import check_output_dir
from rllib_pommer.viz.paper import paper_table

OPPONENTS = ("static", "simple_nobomb", "simple", "simple_nobomb_action", "simple_action")
VARIANTS = ((), ("jitter",), ("action",), ("jitter", "action"))


def _exists(policy: str) -> bool:
    try:
        resolve_policy(policy)
    except ValueError:
        return False
    return True


def default_opponents(team_name: str) -> list[str]:
    """The paper's rows for the team that we can field (told on stderr which are left out)."""
    rows = list((paper_table(team_name) or ("", dict.fromkeys(OPPONENTS)))[1])
    missing = [row for row in rows if not _exists(row)]
    if missing:
        print(f"left out (no such policy here): {', '.join(missing)}", file=sys.stderr)
    return [row for row in rows if row not in missing]


def _finished(out: Path, stem: str, games: int, seed: int) -> bool:
    """Whether the cell `stem` in `out` is played for these `games` and `seed`: its summary is
    there with all its games in the records file. A summary of other games or another seed is
    a ValueError naming it."""
    summary = out / f"{stem}.json"
    if not summary.exists():
        return False
    try:
        played = json.loads(summary.read_text().strip().splitlines()[-1])
        kept = (played["games"], played["seed"])
    except (ValueError, IndexError, KeyError, TypeError):
        return False  # a damaged summary: the cell is played again
    if kept != (games, seed):
        raise ValueError(f"{summary}: a cell of --games {kept[0]} --seed {kept[1]}, not --games "
                         f"{games} --seed {seed}; give another --out (or move the old cells "
                         f"aside)")
    records = out / f"{stem}{RECORDS_SUFFIX}"
    return records.is_file() and len(read_rows(records)) == games


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--team", required=True)
    parser.add_argument("--games", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--opponents", nargs="+", help="default: the paper's rows for the team")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--workers", type=int, default=None, help="processes (default: cores)")
    args = parser.parse_args(argv)
    team_name = Path(args.team).stem
    cells = [("+".join((team_name, *filters)) + f"__vs__{vs}", vs, filters)
             for vs in args.opponents or default_opponents(team_name) for filters in VARIANTS]
    try:
        check_output_dir(args.out, "--out")
        done = {stem for stem, _, _ in cells if _finished(args.out, stem, args.games, args.seed)}
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    for stem, vs, filters in cells:
        records, summary = args.out / f"{stem}{RECORDS_SUFFIX}", args.out / f"{stem}.json"
        if stem in done:
            continue
        argv = ["--team", args.team, "--vs", vs, "--games", str(args.games), "--seed",
                str(args.seed), "--records", str(records), "--json",
                "--force"]  # a cell not finished is played again over its partial file
        if filters:
            argv += ["--filters", ",".join(filters)]
        if args.workers:
            argv += ["--workers", str(args.workers)]
        print(f"== {stem}", flush=True)
        tmp = summary.with_suffix(".json.tmp")
        stdout = sys.stdout
        with open(tmp, "w") as f:
            sys.stdout = _Tee(stdout, f)
            try:
                code = evaluate(argv)
            finally:
                sys.stdout = stdout
        if code != 0:
            return code
        last = tmp.read_text().strip().splitlines()[-1]
        summary.write_text(json.dumps({**json.loads(last), "team": team_name}) + "\n")
        tmp.unlink()
    return 0


class _Tee:
    """Echo the arena's table to the console while keeping its JSON line for the sidecar."""

    def __init__(self, *streams):
        self.streams = streams

    def write(self, text):
        for stream in self.streams:
            stream.write(text)

    def flush(self):
        for stream in self.streams:
            stream.flush()


if __name__ == "__main__":
    sys.exit(main())
