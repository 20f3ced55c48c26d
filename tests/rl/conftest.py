"""For the RL tests (beside tests/conftest.py's Ray instance and throwaway pi weights): an env that
reports what it executed, a smoke run of a curriculum, and the project's campaign run as
committed."""

from __future__ import annotations

import io
import subprocess
import tarfile
from pathlib import Path

import numpy as np
import pytest
import torch
from ray.tune.registry import register_env

from rllib_pommer.rl.env import PommeEnv

ECHO_ENV = "pommerman_echo"


class EchoEnv(PommeEnv):
    """Reports in each info the action the env executed for that agent on the step (an int in
    Team, [move, word, word] in TeamRadio), to compare with what the connector stored."""

    def step(self, action_dict):
        out = super().step(action_dict)
        for agent, info in out[4].items():
            info["executed"] = np.asarray(action_dict[agent]).tolist()
        return out


register_env(ECHO_ENV, EchoEnv)


def snapshot(module) -> dict:
    """A copy of a module's weights."""
    return {k: v.detach().clone() for k, v in module.state_dict().items()}


def train_curriculum(algo, curriculum) -> list[dict]:
    """Train `algo` (built from `curriculum`) until the curriculum's episodes are played; per
    iteration: the stage in force when it began, whether the learner's pi and vf moved, and
    RLlib's result."""
    from rllib_pommer.curriculum.names import LEARNER

    learner = algo.learner_group._learner.module[LEARNER]
    iterations, stage = [], 0
    while True:
        pi, vf = snapshot(learner.pi), snapshot(learner.vf)
        result = algo.train()
        iterations.append({"stage": stage, "pi_changed": _changed(pi, snapshot(learner.pi)),
                           "vf_changed": _changed(vf, snapshot(learner.vf)), "result": result})
        stage = result["curriculum"]["stage"]
        if result["curriculum"]["episodes"] >= curriculum.total_episodes:
            return iterations


def smoke_run(name: str, pi_weights, folder: Path) -> dict:
    """The curriculum `name` trained in-process on the echo env to its end: the learner's
    start (pi weights, radio or not, action space), per-iteration results, 300 sampled steps,
    a checkpoint in `folder`, the trained pi and vf, and the stage each mapping ended at."""
    from rllib_pommer.curriculum.curriculum import load_curriculum
    from rllib_pommer.curriculum.names import LEARNER
    from rllib_pommer.rl.config import build_config

    curriculum = load_curriculum(name)
    config = build_config(curriculum, pi_weights=pi_weights, env=ECHO_ENV)
    algo = config.build_algo()
    learner = algo.learner_group._learner.module[LEARNER]
    start = {"pi": snapshot(learner.pi), "radio": learner.radio, "space": learner.action_space}
    iterations = train_curriculum(algo, curriculum)
    episodes = algo.env_runner.sample(num_timesteps=300, explore=True)
    checkpoint = algo.save(str(folder)).checkpoint.path
    trained = {"pi": snapshot(learner.pi), "vf": snapshot(learner.vf)}
    mappings = (algo.config.policy_mapping_fn.stage, algo.env_runner.config.policy_mapping_fn.stage)
    algo.stop()
    return {"config": config, "curriculum": curriculum, "start": start, "iterations": iterations,
            "episodes": episodes, "checkpoint": checkpoint, "trained": trained,
            "mappings": mappings}


def learner_episodes(episodes) -> list:
    """The learner's non-empty single-agent episodes in sampled multi-agent episodes."""
    from rllib_pommer.curriculum.names import LEARNER

    return [single for episode in episodes for single in episode.agent_episodes.values()
            if single.module_id == LEARNER and len(single)]


def log_softmax(x) -> np.ndarray:
    """log-probabilities of logits (float64), as a categorical distribution's."""
    x = np.asarray(x, np.float64)
    x = x - x.max(-1, keepdims=True)
    return x - np.log(np.exp(x).sum(-1, keepdims=True))


def _changed(before: dict, after: dict) -> bool:
    return any(not torch.equal(before[k], after[k]) for k in before)


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
