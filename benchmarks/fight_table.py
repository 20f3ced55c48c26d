"""How teams fight: win / loss / tie and who killed whom, team by opponent, vanilla, seats balanced.

    python benchmarks/fight_table.py --teams simple imitation ppo ppo_team \
        --vs static simple_nobomb simple ppo_team --games 400 --seed 20261204 --out runs/fight
    python benchmarks/fight_table.py --teams campaign/league/stages/2-league_5k \
        campaign/league_easy_to_hard/stages/4-league --vs static simple_nobomb simple ppo_team \
        --games 200 --out runs/recipes_5k

A team may be any policy name or path the arena plays (a run's stage checkpoint folder, or
`RUN@snapshot_k` for a self-play snapshot). Each cell is an arena match written as
`<team>__vs__<opponent>.jsonl.gz` under --out, kept when a rerun asks for the same games and seed
(so an interrupted table resumes) and refused when it was played otherwise. Per cell: team A's
rates, the opponents its team killed per game, the opponents' own-bomb deaths per game, its own,
and the bombs each of its agents laid per game (`game/kills.py`). The table goes to stdout and
`--out/fight.md`. Not part of CI: a long measurement.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from rllib_pommer.arena.match import MatchSpec, play_match
from rllib_pommer.arena.records import RECORDS_SUFFIX, game_record, summarise, write_records
from rllib_pommer.viz.matches import read_rows


def _label(team: str) -> str:
    path = Path(team.split("@")[0])
    if path.suffix == ".toml":  # a policy file: name it as the file names it
        return path.stem
    if len(path.parts) > 1:  # a run folder: name it by run and stage
        return "/".join(Path(team).parts[-3:]).replace("/stages/", ":")
    return team


def _cell(team: str, vs: str, games: int, seed: int, out: Path, workers: int | None) -> dict:
    path = out / f"{_label(team).replace('/', '_').replace(':', '_')}__vs__{vs}{RECORDS_SUFFIX}"
    if path.is_file():
        records = [game_record(row) for row in read_rows(path)]
        if len(records) != games or {r.seed for r in records} != {seed}:
            raise SystemExit(f"error: {path} holds {len(records)} games of seed(s) "
                             f"{sorted({r.seed for r in records})}, not {games} of seed {seed}; "
                             f"remove it or pick another --out")
        return summarise(records)
    start = time.monotonic()
    records = play_match(MatchSpec(team, vs, games, seed=seed), workers)
    write_records(path, records)
    print(f"{_label(team)} vs {vs}: {games} games in {time.monotonic() - start:.0f} s",
          file=sys.stderr)
    return summarise(records)


def _row(team: str, vs: str, s: dict) -> str:
    return (f"| {_label(team)} | {vs} | {s['win']:.3f} / {s['loss']:.3f} / {s['tie']:.3f} | "
            f"{s['kills_a_per_game']:.2f} | {s['suicides_b_per_game']:.2f} | "
            f"{s['suicides_a_per_game']:.2f} | {s['bombs_per_agent_a']:.1f} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--teams", nargs="+", required=True)
    parser.add_argument("--vs", nargs="+", required=True)
    parser.add_argument("--games", type=int, default=400)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--workers", type=int, default=None,
                        help="processes playing games (default: all cores)")
    args = parser.parse_args(argv)
    if args.games <= 0:
        parser.error(f"--games must be positive, got {args.games}")
    if args.workers is not None and args.workers <= 0:
        parser.error(f"--workers must be positive, got {args.workers}")
    if args.out.exists() and not args.out.is_dir():
        parser.error(f"--out {args.out} is a file, not a folder")
    args.out.mkdir(parents=True, exist_ok=True)
    lines = [f"{args.games} games a cell, seed {args.seed}, seats balanced, no filters. Kills: "
             "opponents killed by the team's fire, per game; suicides: agents dead in their own "
             "blast, per game; bombs: laid per agent per game.", "",
             "| team | vs | win / loss / tie | kills | their suicides | our suicides | bombs |",
             "|---|---|---|---|---|---|---|"]
    for team in args.teams:
        for vs in args.vs:
            cell = _cell(team, vs, args.games, args.seed, args.out, args.workers)
            lines.append(_row(team, vs, cell))
    table = "\n".join(lines) + "\n"
    (args.out / "fight.md").write_text(table)
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
