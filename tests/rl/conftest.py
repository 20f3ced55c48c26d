"""One Ray instance for the RL tests (2 CPUs, no dashboard), throwaway pi weights, and the
project's campaign run as committed."""

from __future__ import annotations

import io
import subprocess
import tarfile
from pathlib import Path

import pytest
import torch

from rllib_pommer.imitation.network import PommerNet


@pytest.fixture(scope="session")
def ray_session():
    import ray

    torch.set_num_threads(1)
    torch.set_flush_denormal(True)
    ray.init(address="local", num_cpus=2, include_dashboard=False)
    yield
    ray.shutdown()


@pytest.fixture(scope="session")
def pi_weights(tmp_path_factory):
    """A randomly initialised PommerNet state_dict (never the shipped imitation weights)."""
    torch.manual_seed(0)
    path = tmp_path_factory.mktemp("weights") / "pi.pt"
    torch.save(PommerNet().state_dict(), path)
    return path


REPO = Path(__file__).resolve().parents[2]
CAMPAIGN = "campaign/paper"
CURRICULUM = "paper"  # the campaign's schedule


@pytest.fixture
def committed_campaign(tmp_path) -> Path:
    """The campaign folder as committed (the working copy may be a live run's), under tmp_path."""
    archive = subprocess.run(["git", "archive", "HEAD", CAMPAIGN], cwd=REPO, capture_output=True)
    if archive.returncode != 0:
        pytest.skip(f"no committed {CAMPAIGN} here ({archive.stderr[:200]!r})")
    with tarfile.open(fileobj=io.BytesIO(archive.stdout)) as tar:
        tar.extractall(tmp_path, filter="data")
    return tmp_path / CAMPAIGN
