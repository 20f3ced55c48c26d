"""Which expert makes the better clone: behaviour cloning on SimpleAgent's games beside the same
cloning on the search agent's, at an equal number of expert games (issue 51).

    python benchmarks/expert_clones.py --games 1000 --out runs/expert_clones
    python benchmarks/expert_clones.py --games 200 --experts simple search_fast --out runs/quick

For each expert, in turn: `collect --expert E --games N --seed S --label-draws K` (the same games
and seeds for every expert: game g is the arena's game g of four agents of that expert), then
`imitate` with the same settings on its data (the soft targets of the label draws), then the
clone, greedy as the shipped clones play, vanilla against SimpleAgent, SimpleAgent_NoBomb and
StaticAgent (`fight_table.py`, seats balanced). Every step resumes as its job does, so an
interrupted comparison goes on where it stopped. The folder holds each expert's dataset
(`data_E`), clone (`clone_E`, `clone_E.toml`), the cells (`fight/`) and `clones.md`, the table:
expert games, rows, what collecting cost, the clone's validation accuracy and its results. The
cost is the CPU seconds of the collecting processes, kept in `costs.json` by the invocation that
finished collecting (one that resumed an interrupted collection counts only its own part). Not
part of CI: a long measurement.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

from rllib_pommer.arena.records import read_records, summarise
from rllib_pommer.data.dataset import open_dataset
from rllib_pommer.util.errors import report_error

ROOT = Path(__file__).resolve().parent.parent
OPPONENTS = ("simple", "simple_nobomb", "static")
sys.path.insert(0, str(ROOT / "benchmarks"))
from fight_table import cell_path  # noqa: E402  (a sibling script)


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _run(command: list[str]) -> tuple[float, float]:
    """Run a job to its end (its own output shown); its wall and CPU seconds, its children's
    included."""
    print("$", " ".join(command), file=sys.stderr, flush=True)
    start, cpu = time.monotonic(), _children_cpu()
    subprocess.run(command, check=True, cwd=ROOT)
    return time.monotonic() - start, _children_cpu() - cpu


def _policy_toml(clone: Path) -> Path:
    return clone.with_suffix(".toml")


def compare(args: argparse.Namespace) -> str:
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    costs_file = out / "costs.json"
    costs = json.loads(costs_file.read_text()) if costs_file.is_file() else {}
    python = sys.executable
    for expert in args.experts:
        data, clone = out / f"data_{expert}", out / f"clone_{expert}"
        if expert not in costs:  # collected (or finished) by this run: its cost is measured
            wall, cpu = _run([python, "-m", "rllib_pommer.collect", "--expert", expert,
                              "--games", str(args.games), "--seed", str(args.seed),
                              "--label-draws", str(args.label_draws), "--out", str(data),
                              "--workers", str(args.workers)])
            costs[expert] = {"collect_wall_s": wall, "collect_cpu_s": cpu}
            costs_file.write_text(json.dumps(costs, indent=1) + "\n")
        if not (clone / "metrics.json").is_file():
            _run([python, "-m", "rllib_pommer.imitate", "--data", str(data), "--out", str(clone),
                  "--epochs", str(args.epochs), "--seed", str(args.seed), "--threads", "1"])
    teams = [str(_policy_toml(out / f"clone_{expert}")) for expert in args.experts]
    _run([python, str(ROOT / "benchmarks" / "fight_table.py"), "--teams", *teams,
          "--vs", *OPPONENTS, "--games", str(args.eval_games), "--seed", str(args.seed),
          "--out", str(out / "fight"), "--workers", str(args.workers)])
    lines = [f"Clones of each expert: {args.games} expert games (seed {args.seed}, "
             f"{args.label_draws} label draws), {args.epochs} epoch(s) of behaviour cloning; "
             f"each clone vanilla, {args.eval_games} games a cell, seats balanced. Win / loss / "
             f"tie, then the opponents killed by the clone's team per game.", "",
             "| expert | rows | collect CPU s | expert games / CPU s | clone val. accuracy | "
             + " | ".join(f"vs {vs}" for vs in OPPONENTS) + " |",
             "|---|---|---|---|---|" + "---|" * len(OPPONENTS)]
    for expert, team in zip(args.experts, teams, strict=True):
        rows = open_dataset(out / f"data_{expert}").num_samples
        metrics = json.loads((out / f"clone_{expert}" / "metrics.json").read_text())
        cpu = costs[expert]["collect_cpu_s"]
        cells = []
        for vs in OPPONENTS:
            s = summarise(read_records(cell_path(out / "fight", team, vs)))
            cells.append(f"{s['win']:.3f} / {s['loss']:.3f} / {s['tie']:.3f}, "
                         f"kills {s['kills_a_per_game']:.2f}")
        lines.append(f"| {expert} | {rows:,} | {cpu:,.0f} | {args.games / cpu:.2f} | "
                     f"{metrics['validation_accuracy']:.3f} | " + " | ".join(cells) + " |")
    table = "\n".join(lines) + "\n"
    (out / "clones.md").write_text(table)
    return table


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/expert_clones.py", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--games", type=int, default=1000, help="expert games per expert")
    parser.add_argument("--experts", nargs="+", default=["simple", "search"])
    parser.add_argument("--seed", type=int, default=2019)
    parser.add_argument("--label-draws", type=int, default=16)
    parser.add_argument("--epochs", type=int, default=2)
    parser.add_argument("--eval-games", type=int, default=1000)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    for name in ("games", "epochs", "eval_games", "workers"):
        if getattr(args, name) <= 0:
            parser.error(f"--{name.replace('_', '-')} must be positive, got {getattr(args, name)}")
    try:
        print(compare(args))
    except (ValueError, OSError, subprocess.CalledProcessError) as exc:
        return report_error(exc)
    return 0


if __name__ == "__main__":
    sys.exit(main())
