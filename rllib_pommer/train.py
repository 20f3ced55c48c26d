"""PPO from the imitation policy through a curriculum (Meisheri et al. 2019), on Ray RLlib.

    python -m rllib_pommer.train [--curriculum NAME|FILE] [--out RUN_DIR] [--resume]
                                 [--address RAY_ADDRESS] [--pi-weights FILE]
    python -m rllib_pommer.train --out RUN_DIR --pack

Curricula are TOML files in `curriculum/` (default "quick"; "paper" is the paper's schedule). The
run directory (default runs/<curriculum name>) gets RLlib checkpoints and TensorBoard logs;
`--resume` continues an interrupted run from its last checkpoint. The arena plays a run's learner
by its directory: `python -m rllib_pommer.evaluate --team runs/quick --vs static`.

`--pack` shrinks a stopped run to what resuming needs (newest checkpoint, stage checkpoints, a
small history.csv of the results), so it can be committed or copied and continued with
`--resume` on another machine, at another path.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

DEFAULT_CURRICULUM = "quick"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.train", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--curriculum", default=DEFAULT_CURRICULUM,
                        help="a name in curriculum/ or a .toml path (default: %(default)s)")
    parser.add_argument("--out", type=Path, help="run directory (default: runs/<name>)")
    parser.add_argument("--resume", action="store_true", help="continue the run in --out")
    parser.add_argument("--address", help="an existing Ray cluster (HOST:PORT or 'auto')")
    parser.add_argument("--pi-weights", help="pi state_dict to start from (overrides the file)")
    parser.add_argument("--num-env-runners", type=int, default=0,
                        help="remote env runners (0: sample in the driver; use more on a cluster)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--pack", action="store_true",
                        help="shrink the stopped run in --out for another machine, then exit")
    args = parser.parse_args(argv)
    if args.pack:
        return _pack(parser, args.out)

    # Imports after parsing, so --help is instant.
    import ray

    from .rl import ray_session
    from .rl.config import check_pi_weights
    from .rl.curriculum import load_curriculum
    from .rl.training import RayStartError, check_run_dir, init_ray, resumes_from_checkpoint, train

    try:  # everything that can be checked is checked before Ray starts
        if args.num_env_runners < 0:
            raise ValueError(f"--num-env-runners must be 0 or more, got {args.num_env_runners}")
        curriculum = load_curriculum(args.curriculum)
        out = args.out or Path("runs") / curriculum.name
        ended = ray_session.reap(out)  # what a SIGKILLed run in `out` left running
        if ended:
            print(f"ended {len(ended)} Ray processes left by the killed run in {out}",
                  file=sys.stderr)
        check_run_dir(out, args.resume)
        if not resumes_from_checkpoint(out, args.resume):  # else pi comes from the checkpoint
            check_pi_weights(Path(args.pi_weights) if args.pi_weights else curriculum.pi_weights)
        init_ray(args.address)
        if args.address is None:  # our own Ray: note it, for the next start to clean up after
            ray_session.record(out)
    except ValueError as exc:
        parser.error(str(exc))
    except RayStartError as exc:  # not the user's input: one line and exit 1, no traceback
        ray.shutdown()
        print(f"error: {exc}", file=sys.stderr)
        return 1
    try:
        result = train(curriculum, out, resume=args.resume, pi_weights=args.pi_weights,
                       num_env_runners=args.num_env_runners, seed=args.seed)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    finally:
        ray.shutdown()
    checkpoint = result.checkpoint.path if result.checkpoint else "-"
    episodes = result.metrics.get("curriculum", {}).get("episodes", 0)
    if episodes < curriculum.total_episodes:
        print(f"stopped at episode {episodes} of {curriculum.total_episodes}: {result.path} "
              f"(checkpoint {checkpoint}); continue with --resume --out {out}")
        return 130
    print(f"done: {result.path} (checkpoint {checkpoint})")
    return 0


def _pack(parser: argparse.ArgumentParser, out: Path | None) -> int:
    if out is None:
        parser.error("--pack needs --out RUN_DIR")
    from .rl.training import pack_run

    try:
        kept = pack_run(out)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    for trial, checkpoint in kept.items():
        print(f"{out / trial}: kept {checkpoint}, results folded into history.csv")
    print(f"{out}: {size / 2**20:.1f} MiB; continue anywhere with "
          f"`python -m rllib_pommer.train --curriculum NAME --out {out} --resume`")
    return 0


if __name__ == "__main__":
    sys.exit(main())
