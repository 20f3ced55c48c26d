"""How teams fight: win / loss / tie and who killed whom, team by opponent, vanilla, seats balanced.

    python benchmarks/fight_table.py --teams simple imitation ppo ppo_team \
        --vs static simple_nobomb simple ppo_team --games 400 --seed 20261204 --out runs/fight
    python benchmarks/fight_table.py --teams campaign/league/stages/2-league_5k \
        campaign/league_easy_to_hard/stages/4-league --vs static simple_nobomb simple ppo_team \
        --games 200 --out runs/recipes_5k

A team may be any policy name or path the arena plays (a policy file, a run's stage checkpoint
folder, or `RUN@snapshot_k` for a self-play snapshot); every one is built before the first cell
plays, so a bad name or path ends the command at once. Each cell is an arena match written whole
under --out as `<team>__vs__<opponent>.jsonl.gz`, named after what it plays: a policy name as it
is, a path with its folders joined by `_` (`DIR/simple.toml` -> `DIR_simple.toml`, not `simple`),
so two teams share a cell file only if they are the same. A cell already there is kept when it
holds this match's games (the same team and opponent, games 0..N-1 of the seed), so an
interrupted table resumes; one holding anything else (other games or seed, another match, a
damaged file) is refused, naming it. Per cell: team A's rates, the opponents its team killed per
game, the opponents' own-bomb deaths per game, its own, and the bombs each of its agents laid per
game (`game/kills.py`). The table goes to stdout and `--out/fight.md`. Errors are one line and
exit 2, as every command's; not part of CI: a long measurement.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from rllib_pommer.agents.registry import make_agent
from rllib_pommer.arena.match import MatchSpec, play_match
from rllib_pommer.arena.records import (
    RECORDS_SUFFIX,
    GameRecord,
    read_records,
    summarise,
    write_records,
)
from rllib_pommer.util.outputs import check_output_dir


def _label(team: str) -> str:
    """A team as the table's rows name it: a run folder by run and stage, else as given."""
    path = Path(team.split("@")[0])
    if path.suffix != ".toml" and len(path.parts) > 1:
        return "/".join(Path(team).parts[-3:]).replace("/stages/", ":")
    return team


def cell_key(policy: str) -> str:
    """What a cell file is named after for a team or an opponent: its name, or its path with
    the folders joined by `_`."""
    return os.path.normpath(policy).strip(os.sep).replace(os.sep, "_")


def cell_path(out: Path, team: str, vs: str) -> Path:
    return out / f"{cell_key(team)}__vs__{cell_key(vs)}{RECORDS_SUFFIX}"


def check_policies(teams: list[str], opponents: list[str]) -> None:
    """Every team and opponent builds, and no two teams (or opponents) share cell files: a
    ValueError naming the first that fails."""
    for flag, names in (("--teams", teams), ("--vs", opponents)):
        keys: dict[str, str] = {}
        for name in names:
            make_agent(name)
            if cell_key(name) in keys:
                other = keys[cell_key(name)]
                raise ValueError(f"{flag}: {name} is listed twice" if other == name else
                                 f"{flag} {other} and {name} would share the cell files "
                                 f"{cell_key(name)}__vs__*: name one of them otherwise")
            keys[cell_key(name)] = name


def _kept(path: Path, spec: MatchSpec) -> list[GameRecord]:
    """The games of the cell file `path`, which must be exactly those of the match `spec`; else a
    ValueError naming the file."""
    try:
        records = read_records(path)
    except ValueError as exc:  # cut short, not JSON Lines, not records: the reader names the file
        raise ValueError(f"{exc}; move the file aside to play the cell again") from None
    played = sorted({(cell_key(r.team), cell_key(r.vs)) for r in records})
    if played != [(cell_key(spec.team), cell_key(spec.vs))]:
        raise ValueError(f"{path}: holds {' and '.join(f'{a} vs {b}' for a, b in played[:2])}, "
                         f"not {spec.team} vs {spec.vs}; move it aside or pick another --out")
    seeds = sorted({r.seed for r in records})
    if seeds != [spec.seed] or sorted(r.game for r in records) != list(range(spec.games)):
        raise ValueError(f"{path}: holds {len(records)} games of seed(s) {seeds}, not games "
                         f"0..{spec.games - 1} of seed {spec.seed}; move it aside or pick another "
                         f"--out")
    return records


def _play(spec: MatchSpec, out: Path, workers: int | None) -> list[GameRecord]:
    """The cell's games, played and written whole (a temporary file renamed, so an
    interrupted write leaves no cell)."""
    start = time.monotonic()
    records = play_match(spec, workers)
    path = cell_path(out, spec.team, spec.vs)
    temporary = path.with_name(".writing-" + path.name)
    write_records(temporary, records)
    os.replace(temporary, path)
    print(f"{_label(spec.team)} vs {spec.vs}: {spec.games} games in "
          f"{time.monotonic() - start:.0f} s", file=sys.stderr)
    return records


def _row(team: str, vs: str, s: dict) -> str:
    return (f"| {_label(team)} | {vs} | {s['win']:.3f} / {s['loss']:.3f} / {s['tie']:.3f} | "
            f"{s['kills_a_per_game']:.2f} | {s['suicides_b_per_game']:.2f} | "
            f"{s['suicides_a_per_game']:.2f} | {s['bombs_per_agent_a']:.1f} |")


def fight_table(args: argparse.Namespace) -> str:
    """Every cell, the kept ones checked before any is played; the table."""
    check_output_dir(args.out, "--out")
    check_policies(args.teams, args.vs)
    specs = [MatchSpec(team, vs, args.games, args.seed) for team in args.teams for vs in args.vs]
    kept = {spec: _kept(cell_path(args.out, spec.team, spec.vs), spec) for spec in specs
            if cell_path(args.out, spec.team, spec.vs).is_file()}
    args.out.mkdir(parents=True, exist_ok=True)
    lines = [f"{args.games} games a cell, seed {args.seed}, seats balanced, no filters. Kills: "
             "opponents killed by the team's fire, per game; suicides: agents dead in their own "
             "blast, per game; bombs: laid per agent per game.", "",
             "| team | vs | win / loss / tie | kills | their suicides | our suicides | bombs |",
             "|---|---|---|---|---|---|---|"]
    for spec in specs:
        records = kept[spec] if spec in kept else _play(spec, args.out, args.workers)
        lines.append(_row(spec.team, spec.vs, summarise(records)))
    table = "\n".join(lines) + "\n"
    (args.out / "fight.md").write_text(table)
    return table


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/fight_table.py", description=__doc__,
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
    try:
        table = fight_table(args)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
