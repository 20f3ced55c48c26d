"""Shared test fixtures: where the recorded reference data live (tests/reference/, in the repo,
so every clone proves the engine's fidelity; tests/reference/README.md says what each file is),
and for the tests that train, one Ray instance (2 CPUs, no dashboard) and throwaway pi weights."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
REFERENCE_DIR = REPO_ROOT / "tests" / "reference"
PUBLIC_GAMES = REFERENCE_DIR / "games_public.jsonl.gz"
RADIO_GAMES = REFERENCE_DIR / "radio" / "games_radio_public.jsonl.gz"
DECISIONS = REFERENCE_DIR / "simpleagent_decisions_public.json"
PAPER_TABLES = REFERENCE_DIR / "paper_tables.tex"


def benchmark_module(name: str):
    """`benchmarks/<name>.py`, loaded from its file (benchmarks/ is no package)."""
    spec = importlib.util.spec_from_file_location(name, REPO_ROOT / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def benchmark_main(name: str):
    """The `main` of `benchmarks/<name>.py`."""
    return benchmark_module(name).main


@pytest.fixture(scope="session")
def public_games() -> Path:
    return PUBLIC_GAMES


@pytest.fixture(scope="session")
def radio_games() -> Path:
    return RADIO_GAMES


@pytest.fixture
def radio_policy(tmp_path):
    """`radio_policy(greedy)`: the path of a learned policy file whose weights are a `RadioNet`
    that really hears and speaks: the shipped imitation net's trunk and moves, with seeded random
    hearing and word heads (a trained radio net's shape, no training needed)."""
    def write(greedy: bool = False, seed: int = 0) -> Path:
        import torch

        from rllib_pommer.agents.registry import resolve_policy
        from rllib_pommer.imitation.learned import load_policy_net

        net = load_policy_net(resolve_policy("imitation").file("weights"), radio=True)
        generator = torch.Generator().manual_seed(seed)
        with torch.no_grad():  # word logits of a few units: sampled words vary
            for weight, scale in ((net.hear.weight, 1.0), (net.speak.weight, 0.05),
                                  (net.speak.bias, 1.0)):
                weight.copy_(scale * torch.randn(weight.shape, generator=generator))
        folder = tmp_path / f"radio_{'greedy' if greedy else 'sampling'}_{seed}"
        folder.mkdir()
        torch.save(net.state_dict(), folder / "pi.pt")
        path = folder / "radio.toml"
        path.write_text(f'kind = "learned"\nweights = "pi.pt"\ngreedy = {str(greedy).lower()}\n'
                        f'description = "a radio net for tests"\n')
        return path
    return write


@pytest.fixture(scope="session")
def ray_session():
    import ray
    import torch

    torch.set_num_threads(1)
    torch.set_flush_denormal(True)
    ray.init(address="local", num_cpus=2, include_dashboard=False)
    yield
    ray.shutdown()


@pytest.fixture(scope="session")
def pi_weights(tmp_path_factory):
    """A randomly initialised PommerNet state_dict (never the shipped imitation weights)."""
    import torch

    from rllib_pommer.imitation.network import PommerNet

    torch.manual_seed(0)
    path = tmp_path_factory.mktemp("weights") / "pi.pt"
    torch.save(PommerNet().state_dict(), path)
    return path
