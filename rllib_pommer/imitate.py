"""`python -m rllib_pommer.imitate --data DIR --out policies/imitation`: behaviour cloning.

Trains the paper's CNN on a dataset made by `python -m rllib_pommer.collect`, then writes into OUT
the policy weights (`pi.pt`, a plain state_dict) and `metrics.json`, and beside OUT a policy file
`<OUT name>.toml` (kind "learned") so the arena, training and serving find the policy by name.
Training state and TensorBoard logs go to OUT/training/; re-running the same command resumes.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import typing
from pathlib import Path

from .bc import WEIGHTS_FILE, BCConfig, train
from .outputs import check_output_dir


def _toml_string(text: str) -> str:
    """A TOML basic string: JSON's escapes are TOML's (non-ASCII kept as is, since TOML refuses
    the surrogate pairs JSON would write for it)."""
    return json.dumps(text, ensure_ascii=False)


def write_policy_file(out: Path, description: str) -> Path:
    policy = out.parent / f"{out.name}.toml"
    # greedy: a clone plays SimpleAgent's most likely action (sampling won 0.165 of 200 games
    # against SimpleAgent, greedy play 0.290, with v1's first-epoch weights)
    policy.write_text(f'kind = "learned"\nweights = {_toml_string(f"{out.name}/{WEIGHTS_FILE}")}\n'
                      f'greedy = true\ndescription = {_toml_string(description)}\n',
                      encoding="utf-8")
    return policy


_HELP = {
    "data": "dataset folder(s) of shards", "out": "policy folder to write",
    "init": "pi weights to start from (fine-tuning)",
    "threads": "torch threads", "checkpoint_every": "batches between training checkpoints",
    "channels_last": "channels-last tensors (faster on CPU)",
    "bf16": "bfloat16 autocast in training (faster on CPUs with AVX-512 BF16)",
    "lr_decay": "cosine decay of the learning rate over the planned batches",
}


def _options(parser: argparse.ArgumentParser) -> None:
    """One option per `BCConfig` field, with its type and default, so they are written once."""
    hints = typing.get_type_hints(BCConfig)
    for field in dataclasses.fields(BCConfig):
        flag = "--" + field.name.replace("_", "-")
        hint = hints[field.name]
        help_text = _HELP.get(field.name)
        if field.default is dataclasses.MISSING:
            many = typing.get_origin(hint) is list
            parser.add_argument(flag, type=Path, required=True, help=help_text,
                                nargs="+" if many else None)
        elif hint is bool:
            parser.add_argument(flag, action=argparse.BooleanOptionalAction,
                                default=field.default, help=help_text)
        else:
            kind = next(t for t in typing.get_args(hint) or (hint,) if t is not type(None))
            parser.add_argument(flag, type=kind, default=field.default,
                                help=help_text or f"default {field.default}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.imitate", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    _options(parser)
    args = parser.parse_args(argv)
    try:
        cfg = BCConfig(**vars(args))
        check_output_dir(args.out, "--out")
        metrics = train(cfg)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    names = ", ".join(d.name for d in cfg.data)
    policy = write_policy_file(args.out, f"Behaviour cloning of SimpleAgent ({names})")
    print(f"validation accuracy {metrics['validation_accuracy']:.4f}, "
          f"loss {metrics['validation_loss']:.4f}; weights {args.out / WEIGHTS_FILE}, "
          f"policy file {policy}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
