"""DAgger data: the clone plays, its shadow SimpleAgents label every state it visits."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from rllib_pommer.collect import main as collect_main
from rllib_pommer.data.collector import Collection, Dagger
from rllib_pommer.data.dagger import TEAM_SEATS, play_dagger_games, seating
from rllib_pommer.data.dataset import open_dataset
from rllib_pommer.game.constants import START_POSITIONS, Action
from rllib_pommer.imitation.learned import greedy_actor
from rllib_pommer.imitation.network import PommerNet
from rllib_pommer.runs.checkpoints import MODULE_STATE

DRAWS = 8


def _policy(tmp_path, stop_bias: float = 0.0):
    """A policy file over a random network; `stop_bias` makes Stop its every greedy choice."""
    torch.manual_seed(0)
    net = PommerNet()
    with torch.no_grad():
        net.head[-1].bias[0] += stop_bias
    torch.save(net.state_dict(), tmp_path / "clone.pt")
    policy = tmp_path / "clone.toml"
    policy.write_text('kind = "learned"\nweights = "clone.pt"\ngreedy = true\n')
    return str(policy)


def test_seats_alternate_teams_and_opponents_take_turns():
    opponents = ("simple", "static")
    assert [seating(g, opponents) for g in range(4)] == [
        ("simple", (0, 2)), ("static", (0, 2)), ("simple", (1, 3)), ("static", (1, 3))]


def test_only_the_clone_is_recorded_and_the_clone_moves_the_game(tmp_path):
    """A clone that always stops never leaves its start cell, though its labels (what SimpleAgent
    would do) are mostly moves: the recorded states are the clone's, the actions SimpleAgent's."""
    act, _ = greedy_actor(_policy(tmp_path, stop_bias=100.0))
    samples = play_dagger_games(3, range(4), act, ("static",), DRAWS)
    for game in range(4):
        rows = samples.game == game
        _, seats = seating(game, ("static",))
        assert set(samples.obs.agent_id[rows]) == set(seats)
    for agent in range(4):
        cells = {tuple(p) for p in samples.obs.position[samples.obs.agent_id == agent]}
        assert cells == {START_POSITIONS[agent]}, f"agent {agent} moved; its clone only stops"
    assert (samples.action_counts.sum(1) == DRAWS).all()
    assert (samples.action != 0).mean() > 0.3  # SimpleAgent wants to move and bomb


def test_same_seed_same_data_and_a_changed_clone_is_refused(tmp_path):
    policy = _policy(tmp_path)
    dagger = Dagger(policy, ("simple", "static"), greedy_actor)
    Collection(tmp_path / "a", 4, 5, 2, DRAWS, dagger).run(workers=1)
    assert collect_main(["--games", "4", "--out", str(tmp_path / "b"), "--seed", "5",
                         "--shard-games", "2", "--workers", "1", "--label-draws", str(DRAWS),
                         "--dagger", policy, "--vs", "simple,static"]) == 0
    a = next(open_dataset(tmp_path / "a").iter_batches(10**6, shuffle=False))
    b = next(open_dataset(tmp_path / "b").iter_batches(10**6, shuffle=False))
    assert all(np.array_equal(x, y) for x, y in zip(a.obs, b.obs, strict=True))
    assert np.array_equal(a.action_counts, b.action_counts) and len(a.action) > 100
    assert set(a.obs.agent_id) == {s for seats in TEAM_SEATS for s in seats}
    _policy(tmp_path, stop_bias=1.0)  # new weights under the same name
    with pytest.raises(ValueError, match="shard-000000.parquet"):
        Collection(tmp_path / "a", 4, 5, 2, DRAWS, dagger)


def test_dagger_needs_label_draws_and_known_opponents(tmp_path):
    policy = _policy(tmp_path)
    with pytest.raises(ValueError, match="label-draws"):
        Collection(tmp_path / "x", 4, 5, 2, 0, Dagger(policy, ("simple",), greedy_actor))
    with pytest.raises(ValueError, match="opponents.*random"):
        Collection(tmp_path / "y", 4, 5, 2, DRAWS, Dagger(policy, ("random",), greedy_actor))
    with pytest.raises(ValueError, match="not a plain learned policy"):
        Collection(tmp_path / "z", 4, 5, 2, DRAWS, Dagger("simple", ("static",), greedy_actor))


def _ppo_run(tmp_path) -> tuple:
    """A PPO run folder as `train` leaves it (tests/runs/test_export.py) whose learner bombs."""
    from ..runs.test_export import _fake_run

    torch.manual_seed(1)
    net = PommerNet()
    with torch.no_grad():  # it lays a bomb and stays: its games are short
        net.head[-1].bias[int(Action.BOMB)] += 100.0
    trial = _fake_run(tmp_path / "run", net)
    return tmp_path / "run", trial


def test_dagger_data_from_a_ppo_run_folder(tmp_path):
    """Issue 40, case 14: a run folder (or its trial, or checkpoint) as --dagger was an
    IsADirectoryError; its learner's module state is the file the dataset pins."""
    run, trial = _ppo_run(tmp_path)
    state = (trial / "checkpoint_000002" / MODULE_STATE).resolve()
    for policy in (run, trial, trial / "checkpoint_000002"):
        assert greedy_actor(str(policy))[1] == state
    assert collect_main(["--games", "1", "--out", str(tmp_path / "d"), "--shard-games", "1",
                         "--workers", "1", "--label-draws", "2", "--dagger", str(run),
                         "--vs", "static"]) == 0
    batch = next(open_dataset(tmp_path / "d").iter_batches(10**6))
    assert len(batch.action) > 0  # labels of the states the bomber visited
