"""Behaviour cloning: cross-entropy from recorded SimpleAgent decisions to `PommerNet` logits.

Streams the Parquet shards (never the whole dataset in RAM), holds out whole games for
validation, logs loss and accuracy to TensorBoard, and checkpoints every few thousand batches so
an interrupted run resumes where it stopped: the shuffle of epoch e is fixed by (seed, e), so
skipping the batches already trained gives the same stream an uninterrupted run sees.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch
from torch.nn import functional as F
from torch.utils.tensorboard import SummaryWriter
from tqdm import tqdm

from .data.dataset import Dataset, open_dataset
from .features import featurize
from .network import PommerNet

WEIGHTS_FILE = "pi.pt"
METRICS_FILE = "metrics.json"


@dataclass
class BCConfig:
    data: Path
    out: Path
    epochs: int = 1
    batch_size: int = 512
    lr: float = 1e-3
    dropout: float = 0.2
    val_fraction: float = 0.05
    seed: int = 0
    threads: int = 2
    checkpoint_every: int = 1000  # batches
    max_batches_per_epoch: int | None = None
    max_val_batches: int | None = 100

    @property
    def training_dir(self) -> Path:
        return self.out / "training"


def set_cpu_options(threads: int) -> None:
    """The CPU settings that matter on small machines (rllib-notes §0): a fixed thread count,
    and flushing denormals, without which sparse binary planes slow the backward pass ~6x."""
    torch.set_num_threads(threads)
    torch.set_flush_denormal(True)


def _batch_tensors(obs, actions) -> tuple[torch.Tensor, torch.Tensor]:
    return torch.from_numpy(featurize(obs)), torch.from_numpy(np.asarray(actions, np.int64))


def evaluate(net: PommerNet, data: Dataset, cfg: BCConfig) -> dict:
    """Mean loss and accuracy on (up to `max_val_batches` batches of) `data`."""
    net.eval()
    loss_sum, correct, count = 0.0, 0, 0
    with torch.no_grad():
        for i, (obs, actions) in enumerate(data.iter_batches(cfg.batch_size, shuffle=False)):
            if cfg.max_val_batches is not None and i >= cfg.max_val_batches:
                break
            x, y = _batch_tensors(obs, actions)
            logits = net(x)
            loss_sum += F.cross_entropy(logits, y, reduction="sum").item()
            correct += (logits.argmax(-1) == y).sum().item()
            count += len(y)
    net.train()
    return {"loss": loss_sum / max(count, 1), "accuracy": correct / max(count, 1),
            "samples": count}


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


def train(cfg: BCConfig) -> dict:
    """Train (or resume), then write `pi.pt` and `metrics.json` into `cfg.out`."""
    set_cpu_options(cfg.threads)
    torch.manual_seed(cfg.seed)
    train_data, val_data = open_dataset(cfg.data).split(cfg.val_fraction, cfg.seed)
    cfg.training_dir.mkdir(parents=True, exist_ok=True)
    net = PommerNet(dropout=cfg.dropout)
    optimizer = torch.optim.Adam(net.parameters(), lr=cfg.lr)
    checkpoint = _Checkpoint(cfg)
    start_epoch, start_batch, seconds = checkpoint.load(net, optimizer)
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
        for batch, (obs, actions) in enumerate(stream):
            if batch >= batches_per_epoch:
                break
            if batch < first:
                continue
            x, y = _batch_tensors(obs, actions)
            logits = net(x)
            loss = F.cross_entropy(logits, y)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            step = epoch * batches_per_epoch + batch
            if batch % 50 == 0:
                accuracy = (logits.argmax(-1) == y).float().mean().item()
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
        print(f"epoch {epoch + 1}: validation loss {val['loss']:.4f}, "
              f"accuracy {val['accuracy']:.4f} on {val['samples']} samples")
        checkpoint.save(net, optimizer, epoch + 1, 0, time.perf_counter() - started)
    writer.close()
    if start_epoch >= cfg.epochs:  # nothing left to train: measure the finished model
        val = evaluate(net, val_data, cfg)
    metrics = {
        "validation_loss": val["loss"], "validation_accuracy": val["accuracy"],
        "validation_samples": val["samples"], "train_samples": train_data.num_samples,
        "batches_per_epoch": batches_per_epoch, "training_seconds": time.perf_counter() - started,
        "config": {k: str(v) if isinstance(v, Path) else v for k, v in asdict(cfg).items()},
    }
    cfg.out.mkdir(parents=True, exist_ok=True)
    _save_atomic(net.state_dict(), cfg.out / WEIGHTS_FILE)
    (cfg.out / METRICS_FILE).write_text(json.dumps(metrics, indent=1))
    return metrics
