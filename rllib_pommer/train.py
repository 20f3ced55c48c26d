"""PPO from the imitation policy through a curriculum (Meisheri et al. 2019), on Ray RLlib.

    python -m rllib_pommer.train [--curriculum NAME|FILE] [--out RUN_DIR] [--resume]
                                 [--address RAY_ADDRESS] [--pi-weights FILE]
                                 [--num-learners N] [--num-gpus-per-learner G]
    python -m rllib_pommer.train --out RUN_DIR [--stop] [--pack]
    python -m rllib_pommer.train --out RUN_DIR --export policies/NAME

Curricula are TOML files in `curriculum/` (default "quick"; "paper" is the paper's schedule). The
run directory (default runs/<curriculum name>) gets RLlib checkpoints and TensorBoard logs;
`--resume` continues an interrupted run from its last checkpoint, with the curriculum the run
noted when it started (another one is refused). The arena plays a run's learner
by its directory: `python -m rllib_pommer.evaluate --team runs/quick --vs static`.

`--stop` stops the run training in RUN_DIR (started by another command) after the iteration
under way, checkpointed, as Ctrl-C would but without losing the iterations since the last
checkpoint, and says the iteration it stopped at. `--pack`
shrinks a stopped run to what resuming needs (newest checkpoint, stage checkpoints, a
small history.csv of the results), so it can be committed or copied and continued with
`--resume` on another machine, at another path. `--export` ships a run's learner as a policy
file and a plain state_dict, as `policies/imitation` is, with a model card (its Fig. 3 and stage
table; `python -m rllib_pommer.report --card POLICY_DIR RECORDS...` adds its results tables).

The options are the fields of `curriculum/settings.RunSettings`; PPO's own settings are the
curriculum's (`curriculum/settings.PPOSettings`, overridable in its [ppo] table).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from .curriculum.settings import RunSettings
from .util.cli_options import add_options, settings_from
from .util.errors import report_error
from .util.outputs import check_output_dir

HELP = {
    "curriculum": "a name in curriculum/ or a .toml path (default: quick; with --resume, the "
                  "run's own, which the run notes in RUN_DIR/curriculum.json)",
    "out": "run directory (default: runs/<name>)",
    "resume": "continue the run in --out",
    "address": "an existing Ray cluster (HOST:PORT or 'auto')",
    "pi_weights": "pi state_dict to start from (overrides the file)",
    "num_env_runners": "remote env runners (0: sample in the learner's process; 2 with "
                       "--torch-threads 2 when the run has a 2-core machine to itself)",
    "seed": "default %(default)s",
    "num_cpus": "CPUs of the Ray instance started here (default %(default)s)",
    "torch_threads": "torch threads of the learner in the algorithm's process (a learner actor "
                     "uses the CPUs it holds) (default %(default)s)",
    "num_learners": "learner actors that split each update, data-parallel (default %(default)s: "
                    "the learner in the algorithm's process)",
    "num_gpus_per_learner": "GPUs of each learner (with 0 learners, of the algorithm's process); "
                            "env runners stay on CPUs (default %(default)s)",
    "num_cpus_per_learner": "Ray CPUs of each learner (with 0 learners, of the algorithm's "
                            "process, at least 1) (default %(default)s)",
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.train", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    add_options(parser, RunSettings, HELP)
    parser.add_argument("--stop", action="store_true",
                        help="stop the run training in --out after the iteration under way, "
                             "checkpointed (then pack it, with --pack), then exit")
    parser.add_argument("--pack", action="store_true",
                        help="shrink the stopped run in --out for another machine, then exit")
    parser.add_argument("--export", type=Path, metavar="POLICY_DIR",
                        help="write the learner of the run in --out as a policy (POLICY_DIR/pi.pt, "
                             "POLICY_DIR.toml; e.g. policies/ppo), then exit")
    args = parser.parse_args(argv)
    if args.stop:
        stopped = _stop(parser, args.out)
        if stopped or not args.pack:
            return stopped
    if args.pack:
        return _pack(parser, args.out)
    if args.export:
        return _export(parser, args.out, args.export)

    # Imports after parsing, so --help is instant.
    import ray

    from .launch.scale import layout_hint
    from .launch.training import RayStartError, start_run, train

    try:  # everything that can be checked is checked before Ray starts
        settings = settings_from(RunSettings, args)
        curriculum, out, start = start_run(settings, lambda line: print(line, file=sys.stderr))
        hint = layout_hint(settings, os.cpu_count() or 1)
        if hint:
            print(hint, file=sys.stderr)
    except ValueError as exc:
        parser.error(str(exc))
    except RayStartError as exc:  # not the user's input: one line and exit 1, no traceback
        ray.shutdown()
        return report_error(exc, 1)
    try:
        result = train(curriculum, out, settings, start)
    except ValueError as exc:
        return report_error(exc)
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


def _stop(parser: argparse.ArgumentParser, out: Path | None) -> int:
    if out is None:
        parser.error("--stop needs --out RUN_DIR")
    from .launch.packing import stop_run

    try:
        stop_run(out)
    except ValueError as exc:
        return report_error(exc)
    return 0


def _pack(parser: argparse.ArgumentParser, out: Path | None) -> int:
    if out is None:
        parser.error("--pack needs --out RUN_DIR")
    from .launch.packing import pack_run

    try:
        kept = pack_run(out)
    except ValueError as exc:
        return report_error(exc)
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    print(f"{out}: kept {kept.relative_to(out.resolve()) if kept else 'no checkpoint'}; "
          f"results folded into each trial's history.csv")
    print(f"{out}: {size / 2**20:.1f} MiB; continue anywhere with "
          f"`python -m rllib_pommer.train --out {out} --resume`")
    return 0


def _export(parser: argparse.ArgumentParser, out: Path | None, target: Path) -> int:
    if out is None:
        parser.error("--export needs --out RUN_DIR")
    from .runs.export import export_policy
    from .runs.history import exported_training
    from .viz.model_card import write_model_card

    try:
        if not target.name or target.name == "..":
            raise ValueError(f"--export: no policy folder named (got {str(target)!r}); give "
                             f"POLICY_DIR, e.g. policies/ppo")
        check_output_dir(target, "--export")
        weights, policy_file = export_policy(out, target)
        card = write_model_card(target, *exported_training(target))
    except ValueError as exc:
        return report_error(exc)
    except OSError as exc:  # a folder that passed the check yet takes no file (/proc, a full disk)
        return report_error(f"--export {target}: cannot write the policy ({exc})")
    print(f"wrote {weights}, {policy_file} and {card}; play it with --team {policy_file}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
