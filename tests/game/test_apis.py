"""The single-game and batched APIs agree, and recorded games replay exactly."""

from __future__ import annotations

import numpy as np
import pytest

from rllib_pommer.game.constants import RADIO_PRESET, TEAM_PRESET
from rllib_pommer.game.engine import Game, Games
from rllib_pommer.game.records import GameRecorder, read_games, write_games
from rllib_pommer.game.state import A_AMMO, A_KICK
from rllib_pommer.game.verify import verify_game

N = 24


def _power_start(state):
    state.agents[:, :, A_KICK] = 1
    state.agents[:, :, A_AMMO] = 3


@pytest.mark.parametrize("config", [TEAM_PRESET, RADIO_PRESET], ids=["team", "radio"])
def test_single_and_batched_apis_agree_step_by_step(config):
    """Also in TeamRadio, where the batch gets (N, 4, 3) arrays and each game four
    [move, word, word] lists; the states compared include the words."""
    rng = np.random.default_rng(0)
    seeds = rng.integers(0, 2**31, N)
    actions = rng.choice([0, 1, 2, 3, 4, 5, 5], size=(400, N, 4))
    if config is RADIO_PRESET:
        actions = np.concatenate([actions[..., None], rng.integers(0, 8, (400, N, 4, 2))], -1)
    batch = Games(N, config)
    batch.reset(seeds)
    _power_start(batch.state)
    batch.observe()
    singles = [Game(config) for _ in range(N)]
    for n, game in enumerate(singles):
        game.reset(int(seeds[n]))
        _power_start(game.state)
    for t in range(400):
        was_done = batch.done.copy()
        obs, rewards, done, _ = batch.step(actions[t])
        for n, game in enumerate(singles):
            if was_done[n]:
                continue
            s_obs, s_rewards, s_done, _ = game.step(actions[t, n].tolist())
            for batched_field, single_field in zip(batch.state, game.state, strict=True):
                assert np.array_equal(batched_field[n], single_field[0])
            for batched_field, single_field in zip(obs, s_obs, strict=True):
                assert np.array_equal(batched_field[n], single_field)
            assert np.array_equal(rewards[n], s_rewards) and done[n] == s_done
        if batch.done.all():
            break
    assert batch.done.sum() > N // 2


def test_recorded_game_exports_and_replays_exactly(tmp_path):
    rng = np.random.default_rng(1)
    records = []
    for seed in (11, 12):
        game = Game(TEAM_PRESET)
        game.reset(seed)
        recorder = GameRecorder(game.batch, 0, seed, agent_mix="RRRR")
        recorder.start()
        done = False
        while not done:
            actions = rng.integers(0, 6, 4)
            done = game.step(actions)[2]
            recorder.step(actions)
        records.append(recorder.finish())
    path = tmp_path / "games.jsonl.gz"
    assert write_games(path, records) == 2
    loaded = list(read_games(path))
    assert loaded == records
    for record in loaded:
        steps, mismatches = verify_game(record)
        assert steps == record["num_steps"] > 0 and mismatches == []


def test_a_recorded_mid_game_position_resumes_identically(public_games):
    record = next(read_games(public_games))
    middle = len(record["steps"]) // 2
    game = Game.from_state(record["steps"][middle]["state"], TEAM_PRESET)
    for entry in record["steps"][middle + 1 :]:
        game.step(entry["actions"])
        assert game.dump() == entry["state"]
