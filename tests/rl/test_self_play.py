"""Self-play: the gate fills a frozen snapshot slot with the learner's pi when the learner beats
its league, the snapshot joins the league at once, and members, weights and the gate's count
come back from a checkpoint moved elsewhere."""

from __future__ import annotations

import shutil

import pytest
import torch
from ray.rllib.algorithms.algorithm import Algorithm

from rllib_pommer.arena.match import MatchSpec, play_match
from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.names import LEARNER
from rllib_pommer.rl.config import build_config
from rllib_pommer.rl.connectors import FIXED_FILTERS_KEY
from rllib_pommer.rl.league import read_book

# Suicide opponents lose every game, so the first block passes the gate; a block is one
# iteration's games at most (gate_games 4) and the second slot stays empty until the next.
SELF_PLAY_SMOKE = """
name = "self_play_smoke"
description = "Self-play, test-sized."
max_steps = 40
[ppo]
train_batch_size = 320
num_epochs = 1
num_envs_per_env_runner = 4
[league]
slots = 2
gate_games = 4
gate_win = 0.5
[defaults]
teammate = "learner"
reward = "raw_kills"
action_filter = 0.0
jitter = 0.0
[[stage]]
name = "league"
opponent = ["suicide", "static_action"]
episodes = 100000
self_play = true
"""


def _same(a: torch.nn.Module, b: torch.nn.Module) -> bool:
    return all(torch.equal(x, y) for x, y in zip(a.state_dict().values(),
                                                 b.state_dict().values(), strict=True))


def test_a_league_curriculum_is_checked(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(SELF_PLAY_SMOKE)
    curriculum = load_curriculum(path)
    assert curriculum.league.slot_ids() == ["snapshot_0", "snapshot_1"]
    assert curriculum.stages[0].self_play and curriculum.policies()[-1] == "static_action"
    for old, new, words in (("gate_win = 0.5", "gate_win = 1.5", r"gate_win must be in"),
                            ("slots = 2", "slot = 2", "unknown key 'slot'"),
                            ("[league]\n", "[leage]\n", "unknown key 'leage'")):
        path.write_text(SELF_PLAY_SMOKE.replace(old, new))
        with pytest.raises(ValueError, match=words):
            load_curriculum(path)
    path.write_text(SELF_PLAY_SMOKE.replace("[league]\nslots = 2\ngate_games = 4\n"
                                            "gate_win = 0.5\n", ""))
    with pytest.raises(ValueError, match="self_play needs a \\[league\\] table"):
        load_curriculum(path)


def test_the_gate_adds_snapshots_that_play_and_survive_a_moved_checkpoint(
        ray_session, pi_weights, tmp_path):
    path = tmp_path / "self_play.toml"
    path.write_text(SELF_PLAY_SMOKE)
    curriculum = load_curriculum(path)
    algo = build_config(curriculum, pi_weights=pi_weights).build_algo()
    try:
        modules = algo.learner_group._learner.module
        first = algo.train()
        assert first["env_runners"]["league_games"] >= 4
        assert first["league"]["filled"] == "snapshot_0" and first["league"]["snapshots"] == 1
        assert _same(modules["snapshot_0"].pi, modules[LEARNER].pi)  # the pi of that moment
        runner = algo.env_runner
        assert _same(runner.module["snapshot_0"].pi, modules[LEARNER].pi)  # synced to sampling
        assert runner.config.policy_mapping_fn.opponent == ("suicide", "static_action",
                                                            "snapshot_0")
        second = algo.train()
        played = {key for key in second["env_runners"] if key.startswith("learner_win_vs_")}
        assert "learner_win_vs_snapshot_0" in played, played
        assert "learner_kills" in second["env_runners"]
        filtered = 0  # static_action's every step goes through the action filter
        for episode in algo.env_runner.sample(num_episodes=12, explore=True):
            for agent, filters in episode.custom_data.get(FIXED_FILTERS_KEY, {}).items():
                assert episode.module_for(agent) == "static_action"
                assert filters.flags == {"action_filter": True}
                filtered += filters.steps
        assert filtered > 0
        book = read_book(algo.learner_group._learner, curriculum.league)
        checkpoint = algo.save_to_path(str(tmp_path / "checkpoint"))
        snapshot_pi = {k: v.clone() for k, v in modules["snapshot_0"].pi.state_dict().items()}
    finally:
        algo.stop()
    moved = tmp_path / "elsewhere" / "checkpoint"
    shutil.copytree(checkpoint, moved)
    shutil.rmtree(checkpoint)
    restored = Algorithm.from_checkpoint(str(moved))
    try:
        learner = restored.learner_group._learner
        assert read_book(learner, curriculum.league) == book
        assert all(torch.equal(learner.module["snapshot_0"].pi.state_dict()[k], v)
                   for k, v in snapshot_pi.items())
        mapping = restored.env_runner.config.policy_mapping_fn
        assert mapping.opponent[:3] == ("suicide", "static_action", "snapshot_0")
        assert _same(restored.env_runner.module["snapshot_0"].pi,
                     learner.module["snapshot_0"].pi)
    finally:
        restored.stop()
    # and the arena plays a snapshot by name, <run or checkpoint>@<slot>, as the learner plays
    (record,) = play_match(MatchSpec(f"{moved}@snapshot_0", "static", 1, seed=2), workers=1)
    assert record.team.endswith("@snapshot_0") and record.length > 0
    with pytest.raises(ValueError, match="no module 'snapshot_7'; its modules: "):
        play_match(MatchSpec(f"{moved}@snapshot_7", "static", 1), workers=1)
