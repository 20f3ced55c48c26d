"""One Ray instance for the RL tests (2 CPUs, no dashboard), and throwaway pi weights."""

from __future__ import annotations

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
