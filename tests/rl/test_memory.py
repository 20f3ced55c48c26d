"""Training with memory (a curriculum's `memory = true`, imitation/recall.py): the learner and its
self-play snapshots read 22 planes, start from 19-plane weights as those play, a 19-plane frozen
opponent plays beside them, and the arena plays the saved learner and snapshot with memory."""

from __future__ import annotations

import pytest
import torch

from rllib_pommer.arena.match import MatchSpec, play_match
from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.names import LEARNER
from rllib_pommer.imitation.learned import load_policy_net
from rllib_pommer.imitation.recall import MEMORY_PLANES
from rllib_pommer.rl.config import build_config
from rllib_pommer.runs.checkpoints import load_checkpoint_net

from .test_self_play import SELF_PLAY_SMOKE

# The self-play smoke league with memory, and a 19-plane frozen opponent beside its snapshots.
MEMORY_SMOKE = SELF_PLAY_SMOKE.replace("max_steps = 40\n", "max_steps = 40\nmemory = true\n") \
    .replace('opponent = ["suicide", "static_action"]', 'opponent = ["suicide", "ppo"]')


def test_a_memory_curriculum_is_checked(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(MEMORY_SMOKE)
    assert load_curriculum(path).memory
    path.write_text(MEMORY_SMOKE.replace("memory = true", "memory = 1"))
    with pytest.raises(ValueError, match="memory must be true or false, got 1"):
        load_curriculum(path)
    path.write_text(MEMORY_SMOKE.replace("memory = true\n", ""))
    assert not load_curriculum(path).memory


def test_a_run_with_memory_trains_on_22_planes_and_its_learner_plays_in_the_arena(
        ray_session, pi_weights, tmp_path):
    path = tmp_path / "memory.toml"
    path.write_text(MEMORY_SMOKE)
    algo = build_config(load_curriculum(path), pi_weights=pi_weights).build_algo()
    try:
        modules = algo.learner_group._learner.module
        start = load_policy_net(pi_weights).state_dict()
        pi = modules[LEARNER].pi
        assert pi.planes == modules[LEARNER].vf.planes == MEMORY_PLANES
        first = pi.state_dict()["convs.0.weight"]
        assert torch.equal(first[:, :19], start["convs.0.weight"])  # as the 19-plane pi
        assert not first[:, 19:].any()  # the memory planes start unheard
        result = algo.train()
        assert result["league"]["filled"] == "snapshot_0"
        assert modules["snapshot_0"].pi.planes == MEMORY_PLANES
        assert modules["ppo"].pi.planes == 19  # a 19-plane opponent reads the first 19
        assert "learner_win_vs_ppo" in result["env_runners"] or \
            "learner_win_vs_suicide" in result["env_runners"]
        assert pi.state_dict()["convs.0.weight"][:, 19:].any()  # and PPO uses them
        checkpoint = algo.save_to_path(str(tmp_path / "checkpoint"))
    finally:
        algo.stop()
    assert load_checkpoint_net(checkpoint).planes == MEMORY_PLANES
    for team in (str(checkpoint), f"{checkpoint}@snapshot_0"):
        records = play_match(MatchSpec(team, "simple", 2, seed=3), workers=1)
        again = play_match(MatchSpec(team, "simple", 2, seed=3), workers=1)
        assert [r.length for r in records] == [r.length for r in again]  # seeded, memory too
        assert all(r.length > 0 for r in records)

