"""Behaviour cloning: cross-entropy from SimpleAgent's decisions to `PommerNet` logits.

The target of a sample is SimpleAgent's action distribution where the dataset recorded one
(`collect --label-draws K`: K tie-breaking draws from the agent's memory, plus the recorded action
as one more draw), else the recorded action alone. SimpleAgent breaks ties at random, so a single
recorded action is a noisy label for about half of all decisions; the counts tell the network how
often each action is right, which the recorded action alone says only over many samples.

Streams the Parquet shards (never the whole dataset in RAM), holds out whole games for
validation, logs loss and accuracy to TensorBoard, and checkpoints every few thousand batches so
an interrupted run resumes where it stopped: the shuffle of epoch e is fixed by (seed, e), so
skipping the batches already trained gives the same stream an uninterrupted run sees.
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch
from torch.nn import functional as F
from torch.utils.tensorboard import SummaryWriter
from tqdm import tqdm

from ..agents import registry
from ..data.dataset import Dataset, open_dataset
from ..data.schema import Batch
from .features import featurize
from .learned import load_policy_net
from .network import PommerNet

WEIGHTS_FILE = "pi.pt"
METRICS_FILE = "metrics.json"


def _whole(low: int):
    return lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= low


# The settings with a range (None, where a field allows it, means no limit): test, what is allowed.
_ALLOWED = {
    "epochs": (_whole(1), "an integer >= 1"),
    "batch_size": (_whole(1), "an integer >= 1"),
    "threads": (_whole(1), "an integer >= 1"),
    "checkpoint_every": (_whole(1), "an integer >= 1"),
    "max_batches_per_epoch": (_whole(1), "an integer >= 1"),
    "max_val_batches": (_whole(1), "an integer >= 1"),
    "max_label_draws": (_whole(0), "an integer >= 0"),
    "lr": (lambda v: 0 < v < math.inf, "a positive number"),
    "final_lr_fraction": (lambda v: 0 <= v <= 1, "in [0, 1]"),
    "dropout": (lambda v: 0 <= v < 1, "in [0, 1)"),
    # Whole games go to validation: none would leave nothing to measure, all nothing to train.
    "val_fraction": (lambda v: 0 < v < 1, "in (0, 1)"),
}


@dataclass
class BCConfig:
    """Every setting of a behaviour-cloning run; `python -m rllib_pommer.imitate` makes one
    option of each field."""
    data: list[Path]  # one or more dataset folders (expert games, DAgger rounds)
    out: Path
    epochs: int = 1
    batch_size: int = 512
    lr: float = 1e-3
    # Cosine decay of the learning rate to `lr * final_lr_fraction` over all planned batches;
    # the rate follows from the batch count alone, so a resumed run continues the same schedule.
    lr_decay: bool = True
    final_lr_fraction: float = 0.05
    dropout: float = 0.2
    val_fraction: float = 0.05
    seed: int = 0
    threads: int = 2
    checkpoint_every: int = 1000  # batches
    max_batches_per_epoch: int | None = None
    max_val_batches: int | None = 100
    # For speed (`bench learn`; docs/measurements.md): channels-last tensors and bfloat16
    # autocast. Validation always runs in float32.
    channels_last: bool = True
    bf16: bool = True
    init: Path | None = None  # start from these pi weights (fine-tuning, e.g. after DAgger)
    # Train on only this many of each sample's counted draws (drawn without replacement, as if
    # the data had been collected with fewer): measures what more draws buy. None: all of them.
    max_label_draws: int | None = None

    def __post_init__(self):
        if isinstance(self.data, (str, Path)):
            self.data = [self.data]
        self.data = [Path(d) for d in self.data]
        for name, (allowed, what) in _ALLOWED.items():
            value = getattr(self, name)
            if value is not None and not allowed(value):
                raise ValueError(f"{name} must be {what}, got {value!r}")

    @property
    def training_dir(self) -> Path:
        return self.out / "training"


def set_cpu_options(threads: int) -> None:
    """The CPU settings that matter on small machines: a fixed thread count, and flushing
    denormals, which the sparse binary planes otherwise produce in the backward pass, slowing it
    several times over (docs/measurements.md)."""
    torch.set_num_threads(threads)
    torch.set_flush_denormal(True)


def soft_targets(actions: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """float32 (B, 6): each row's counted draws plus its recorded action, normalised (a one-hot
    of the recorded action where nothing was counted)."""
    targets = counts.astype(np.float32)
    targets[np.arange(len(actions)), actions] += 1.0
    return targets / targets.sum(1, keepdims=True)


def fewer_draws(counts: np.ndarray, draws: int, rng: np.random.Generator) -> np.ndarray:
    """Counts (B, 6) of `draws` of each row's draws taken without replacement (all of a row's
    draws if it has fewer): the counts a collection with `draws` draws would have recorded."""
    counts = counts.astype(np.int64)
    left = counts.sum(1)
    wanted = np.minimum(left, draws)
    out = np.zeros_like(counts)
    for action in range(counts.shape[1] - 1):  # each action's share given the ones before
        left -= counts[:, action]
        out[:, action] = rng.hypergeometric(counts[:, action], left, wanted)
        wanted -= out[:, action]
    out[:, -1] = wanted
    return out.astype(np.uint8)


def _inputs(obs, cfg: BCConfig) -> torch.Tensor:
    x = torch.from_numpy(featurize(obs))
    return x.contiguous(memory_format=torch.channels_last) if cfg.channels_last else x


def build_net(cfg: BCConfig) -> PommerNet:
    net = PommerNet(dropout=cfg.dropout)
    return net.to(memory_format=torch.channels_last) if cfg.channels_last else net


def train_step(net: PommerNet, optimizer: torch.optim.Optimizer, batch: Batch,
               cfg: BCConfig) -> tuple[torch.Tensor, torch.Tensor]:
    """One update on `batch`; returns the loss and the (float32) logits."""
    with torch.autocast("cpu", dtype=torch.bfloat16, enabled=cfg.bf16):
        logits = net(_inputs(batch.obs, cfg)).float()
    loss = F.cross_entropy(logits, torch.from_numpy(soft_targets(batch.action,
                                                                 batch.action_counts)))
    optimizer.zero_grad()
    loss.backward()
    optimizer.step()
    return loss, logits


def learning_rate(cfg: BCConfig, step: int, total_steps: int) -> float:
    if not cfg.lr_decay or total_steps <= 1:
        return cfg.lr
    progress = min(step / (total_steps - 1), 1.0)
    floor = cfg.lr * cfg.final_lr_fraction
    return floor + (cfg.lr - floor) * 0.5 * (1 + math.cos(math.pi * progress))


def evaluate(net: PommerNet, data: Dataset, cfg: BCConfig) -> dict:
    """On (up to `max_val_batches` batches of) `data`: the mean loss against the targets,
    `accuracy` (greedy action == recorded action) and, over samples with counted draws,
    `mode_accuracy` (greedy action == SimpleAgent's most frequent one) and `expected_agreement`
    (the share of SimpleAgent's draws that chose the greedy action: what the recorded-action
    accuracy tends to on unseen games)."""
    net.eval()
    loss_sum, correct, count = 0.0, 0, 0
    mode_hits, agreement, counted = 0, 0.0, 0
    with torch.no_grad():
        for i, (obs, actions, counts) in enumerate(data.iter_batches(cfg.batch_size,
                                                                    shuffle=False)):
            if cfg.max_val_batches is not None and i >= cfg.max_val_batches:
                break
            logits = net(_inputs(obs, cfg)).float()
            targets = torch.from_numpy(soft_targets(actions, counts))
            loss_sum += F.cross_entropy(logits, targets, reduction="sum").item()
            greedy = logits.argmax(-1).numpy()
            correct += int((greedy == actions).sum())
            count += len(actions)
            draws = counts.sum(1)
            rows = np.flatnonzero(draws)
            mode_hits += int((greedy[rows] == counts[rows].argmax(1)).sum())
            agreement += float((counts[rows, greedy[rows]] / draws[rows]).sum())
            counted += len(rows)
    net.train()
    metrics = {"loss": loss_sum / max(count, 1), "accuracy": correct / max(count, 1),
               "samples": count}
    if counted:
        metrics.update(mode_accuracy=mode_hits / counted, expected_agreement=agreement / counted)
    return metrics


def _describe(metrics: dict) -> str:
    text = f"loss {metrics['loss']:.4f}, accuracy {metrics['accuracy']:.4f}"
    if "mode_accuracy" in metrics:
        text += (f", mode accuracy {metrics['mode_accuracy']:.4f}, expected agreement "
                 f"{metrics['expected_agreement']:.4f}")
    return f"{text} on {metrics['samples']} samples"


def _save_atomic(obj, path: Path) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    torch.save(obj, tmp)
    os.replace(tmp, path)


class _Checkpoint:
    """Model, optimizer and position in the stream, saved atomically and loaded without pickle."""

    def __init__(self, cfg: BCConfig):
        self.path = cfg.training_dir / "checkpoint.pt"

    def load(self, net, optimizer) -> tuple[int, int, float]:
        if not self.path.exists():
            return 0, 0, 0.0
        try:
            state = torch.load(self.path, map_location="cpu", weights_only=True)
            net.load_state_dict(state["model"])
            optimizer.load_state_dict(state["optimizer"])
        except Exception as exc:
            raise ValueError(f"{self.path}: cannot resume from this checkpoint ({exc}); "
                             "delete it to start over") from None
        return int(state["epoch"]), int(state["batch"]), float(state["seconds"])

    def save(self, net, optimizer, epoch: int, batch: int, seconds: float) -> None:
        _save_atomic({"model": net.state_dict(), "optimizer": optimizer.state_dict(),
                      "epoch": epoch, "batch": batch, "seconds": seconds}, self.path)


def check_not_replacing(cfg: BCConfig) -> None:
    """Refuse an `out` that holds a policy this training did not make: its weights or its policy
    file exist, and no training state of an earlier run of this command does (a shipped policy,
    or one `train --export` wrote). Such a policy is replaced only when asked (`--force`)."""
    if _Checkpoint(cfg).path.is_file():
        return  # an earlier run of this command: re-running resumes it
    for path in (cfg.out / WEIGHTS_FILE, policy_file_of(cfg.out)):
        if path.exists():
            raise ValueError(f"--out {cfg.out}: {path} exists (a policy not trained here); "
                             f"pass --force to replace it, or choose another --out")


def train(cfg: BCConfig) -> dict:
    """Train (or resume), then write `pi.pt` and `metrics.json` into `cfg.out`."""
    set_cpu_options(cfg.threads)
    torch.manual_seed(cfg.seed)
    train_data, val_data = open_dataset(*cfg.data).split(cfg.val_fraction, cfg.seed)
    for side, data in (("training", train_data), ("validation", val_data)):
        if data.num_samples == 0:
            raise ValueError(f"val_fraction {cfg.val_fraction} leaves no {side} games in "
                             f"{', '.join(map(str, cfg.data))}: choose another, or more games")
    cfg.training_dir.mkdir(parents=True, exist_ok=True)
    net = build_net(cfg)
    optimizer = torch.optim.Adam(net.parameters(), lr=cfg.lr)
    checkpoint = _Checkpoint(cfg)
    start_epoch, start_batch, seconds = checkpoint.load(net, optimizer)
    if cfg.init is not None and (start_epoch, start_batch) == (0, 0):
        net.load_state_dict(load_policy_net(cfg.init, radio=False).state_dict())
    writer = SummaryWriter(str(cfg.training_dir / "tensorboard"))
    batches_per_epoch = train_data.num_samples // cfg.batch_size + 1
    if cfg.max_batches_per_epoch is not None:
        batches_per_epoch = min(batches_per_epoch, cfg.max_batches_per_epoch)
    started = time.perf_counter() - seconds
    for epoch in range(start_epoch, cfg.epochs):
        first = start_batch if epoch == start_epoch else 0
        stream = train_data.iter_batches(cfg.batch_size, shuffle=True, seed=cfg.seed * 1000 + epoch)
        bar = tqdm(total=batches_per_epoch, initial=first, desc=f"epoch {epoch + 1}/{cfg.epochs}",
                   unit="batch")
        for batch, samples in enumerate(stream):
            if batch >= batches_per_epoch:
                break
            if batch < first:
                continue
            step = epoch * batches_per_epoch + batch
            if cfg.max_label_draws is not None:
                rng = np.random.default_rng([cfg.seed, step])
                samples = samples._replace(action_counts=fewer_draws(
                    samples.action_counts, cfg.max_label_draws, rng))
            for group in optimizer.param_groups:
                group["lr"] = learning_rate(cfg, step, cfg.epochs * batches_per_epoch)
            loss, logits = train_step(net, optimizer, samples, cfg)
            if batch % 50 == 0:
                accuracy = (logits.argmax(-1).numpy() == samples.action).mean()
                writer.add_scalar("train/loss", loss.item(), step)
                writer.add_scalar("train/accuracy", accuracy, step)
                bar.set_postfix(loss=f"{loss.item():.3f}", acc=f"{accuracy:.3f}")
            bar.update(1)
            if (batch + 1) % cfg.checkpoint_every == 0:
                checkpoint.save(net, optimizer, epoch, batch + 1, time.perf_counter() - started)
        bar.close()
        val = evaluate(net, val_data, cfg)
        writer.add_scalar("val/loss", val["loss"], (epoch + 1) * batches_per_epoch)
        writer.add_scalar("val/accuracy", val["accuracy"], (epoch + 1) * batches_per_epoch)
        for name in ("mode_accuracy", "expected_agreement"):
            if name in val:
                writer.add_scalar(f"val/{name}", val[name], (epoch + 1) * batches_per_epoch)
        print(f"epoch {epoch + 1}: validation {_describe(val)}", flush=True)
        checkpoint.save(net, optimizer, epoch + 1, 0, time.perf_counter() - started)
    writer.close()
    if start_epoch >= cfg.epochs:  # nothing left to train: measure the finished model
        val = evaluate(net, val_data, cfg)
    metrics = {
        "validation_loss": val["loss"], "validation_accuracy": val["accuracy"],
        "validation_samples": val["samples"], "train_samples": train_data.num_samples,
        **{f"validation_{name}": val[name] for name in ("mode_accuracy", "expected_agreement")
           if name in val},
        "batches_per_epoch": batches_per_epoch, "training_seconds": time.perf_counter() - started,
        "config": json.loads(json.dumps(asdict(cfg), default=str)),
    }
    cfg.out.mkdir(parents=True, exist_ok=True)
    _save_atomic({k: v.contiguous() for k, v in net.state_dict().items()}, cfg.out / WEIGHTS_FILE)
    (cfg.out / METRICS_FILE).write_text(json.dumps(metrics, indent=1))
    return metrics


def policy_file_of(out: Path) -> Path:
    """The policy file of the weights folder `out`: `<out name>.toml` beside it."""
    return out.parent / f"{out.name}.toml"


def write_policy_file(out: Path, description: str, greedy: bool = True) -> Path:
    """`<out name>.toml` beside the weights folder `out`: the policy file (kind "learned",
    written by the registry, which reads it) by which the arena, training and serving find the
    policy by name. Greedy by default: a clone plays SimpleAgent's most likely action, which
    wins more often than sampling from it (docs/measurements.md)."""
    return registry.write_policy_file(policy_file_of(out), "learned", description,
                                      weights=f"{out.name}/{WEIGHTS_FILE}", greedy=greedy)
