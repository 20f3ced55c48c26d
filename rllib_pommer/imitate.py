"""`python -m rllib_pommer.imitate --data DIR --out policies/imitation`: behaviour cloning.

Trains the paper's CNN on a dataset made by `python -m rllib_pommer.collect`, then writes into OUT
the policy weights (`pi.pt`, a plain state_dict) and `metrics.json`, and beside OUT a policy file
`<OUT name>.toml` (kind "learned") so the arena, training and serving find the policy by name.
Training state and TensorBoard logs go to OUT/training/; re-running the same command resumes.
A policy already in OUT (weights or policy file) that OUT/training/ did not make here, such as a
shipped one, is never replaced without `--force`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .data.schema import read_meta
from .imitation.bc import (
    WEIGHTS_FILE,
    BCConfig,
    check_not_replacing,
    train,
    write_policy_file,
)
from .util.cli_options import add_options, settings_from
from .util.errors import report_error
from .util.outputs import check_output_dir

_HELP = {
    "data": "dataset folder(s) of shards", "out": "policy folder to write",
    "init": "pi weights to start from (fine-tuning)",
    "threads": "torch threads", "checkpoint_every": "batches between training checkpoints",
    "channels_last": "channels-last tensors (faster on CPU)",
    "bf16": "bfloat16 autocast in training (faster on CPUs with AVX-512 BF16)",
    "lr_decay": "cosine decay of the learning rate over the planned batches",
}


def experts(data: list[Path]) -> str:
    """Who played each dataset folder, as the clone's description names it: SimpleAgent, a
    search policy, or SimpleAgent labelling a DAgger clone's states (its first shard says)."""
    names = []
    for folder in data:
        shards = sorted(Path(folder).glob("shard-*.parquet"))
        meta = read_meta(shards[0])[1] if shards else None
        who = ("SimpleAgent" if meta is None or meta.agents == "simple" else
               f"the search agent {meta.policy}" if meta.agents == "search" else
               f"SimpleAgent on {meta.policy}'s states")
        names.append(f"{who} ({Path(folder).name})")
    return ", ".join(names)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.imitate", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    add_options(parser, BCConfig, _HELP)
    parser.add_argument("--force", action="store_true",
                        help="replace the policy already in --out (its weights and policy file)")
    args = parser.parse_args(argv)
    try:
        cfg = settings_from(BCConfig, args)
        check_output_dir(args.out, "--out")
        if not args.force:
            check_not_replacing(cfg)
        metrics = train(cfg)
    except ValueError as exc:
        return report_error(exc)
    policy = write_policy_file(args.out, f"Behaviour cloning of {experts(cfg.data)}")
    print(f"validation accuracy {metrics['validation_accuracy']:.4f}, "
          f"loss {metrics['validation_loss']:.4f}; weights {args.out / WEIGHTS_FILE}, "
          f"policy file {policy}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
