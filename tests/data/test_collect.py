"""Collection: same seed same data, every decision recorded exactly as played, crash-safe resume."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from rllib_pommer.agents.simple import SimpleAgent
from rllib_pommer.collect import main
from rllib_pommer.data.collector import Collection, plan_shards
from rllib_pommer.data.expert import play_games
from rllib_pommer.data.schema import SHARD_GLOB, encode, read_meta
from rllib_pommer.game.seeding import game_seeds

from .conftest import (
    TINY_GAMES,
    TINY_LABEL_DRAWS,
    TINY_SEED,
    TINY_SHARD_GAMES,
    read_all,
    replay_against_rows,
    row_keys,
)


def _tiny(out, games: int, seed: int) -> Collection:
    """A collection in the tiny dataset's shard size and label draws."""
    return Collection(out, games, seed, TINY_SHARD_GAMES, TINY_LABEL_DRAWS)


def test_same_seed_same_dataset_whatever_the_workers(tiny_dataset, tmp_path):
    _tiny(tmp_path / "two", TINY_GAMES, TINY_SEED).run(workers=2)
    assert read_all(tmp_path / "two").equals(read_all(tiny_dataset))
    _tiny(tmp_path / "other", TINY_GAMES, TINY_SEED + 1).run(workers=1)
    assert not read_all(tmp_path / "other").equals(read_all(tiny_dataset))


def test_refilled_batch_slots_play_the_same_games(tiny_dataset):
    """One slot playing the three games in turn (memory rows reset in between) gives the same
    shard as three slots playing them side by side."""
    meta = plan_shards(TINY_GAMES, TINY_SEED, TINY_SHARD_GAMES, TINY_LABEL_DRAWS)[0]
    one_slot = encode(play_games(TINY_SEED, range(TINY_SHARD_GAMES), batch_games=1,
                                 label_draws=TINY_LABEL_DRAWS), meta)
    shard, _ = read_meta(tiny_dataset / "shard-000000.parquet")
    assert one_slot.replace_schema_metadata(None).equals(shard.read().replace_schema_metadata(None))


def test_one_row_per_decision_of_each_living_agent(tiny_dataset):
    table = read_all(tiny_dataset)
    keys = row_keys(table)
    assert len(np.unique(keys, axis=0)) == len(keys)
    assert set(keys[:, 0]) == set(range(TINY_GAMES))
    for game, agent in {(g, a) for g, _, a in keys}:
        steps = keys[(keys[:, 0] == game) & (keys[:, 2] == agent), 1]
        assert list(steps) == list(range(len(steps)))  # from step 0 until the agent dies
    alive = np.frombuffer(table.column("alive").combine_chunks().buffers()[1], np.bool_)
    assert alive.reshape(-1, 4)[np.arange(len(keys)), keys[:, 2]].all()


@pytest.mark.parametrize("game", [0, 4])
def test_samples_read_back_equal_a_replay_of_the_game(tiny_dataset, game):
    """Replay with the single-game API and one SimpleAgent object per seat, seeded as the
    collector seeds game `game`: every observation and action must come back from the reader."""
    table = read_all(tiny_dataset)
    keys = row_keys(table)
    board_seed, _ = game_seeds(TINY_SEED, game)
    assert set(table.column("board_seed").to_numpy()[keys[:, 0] == game]) == {board_seed}
    checked, unmatched = replay_against_rows(tiny_dataset, TINY_SEED, game,
                                             [SimpleAgent() for _ in range(4)])
    assert checked > 100 and not unmatched


def test_label_draws_leave_the_games_alone_and_sample_the_recorded_policy(tiny_dataset):
    """With or without soft targets the same games are played; each row's counts add up to the
    draws, and the recorded action (one more sample of the same distribution) is usually among
    the counted ones, about as often as two SimpleAgents agree (0.78 on reference games)."""
    games = range(TINY_SHARD_GAMES)
    plain = play_games(TINY_SEED, games)
    soft = play_games(TINY_SEED, games, label_draws=TINY_LABEL_DRAWS)
    assert np.array_equal(plain.action, soft.action) and not plain.action_counts.any()
    assert (soft.action_counts.sum(1) == TINY_LABEL_DRAWS).all()
    recorded_share = soft.action_counts[np.arange(len(soft.action)), soft.action].mean()
    assert 0.65 < recorded_share / TINY_LABEL_DRAWS < 0.95
    undecided = (soft.action_counts.max(1) < TINY_LABEL_DRAWS).mean()
    assert 0.05 < undecided < 0.6  # random tie-breaks are common, but most decisions are fixed
    again = play_games(TINY_SEED, games, label_draws=TINY_LABEL_DRAWS)
    assert np.array_equal(again.action_counts, soft.action_counts)


def _collect_command(out, games, shard_games) -> list[str]:
    return ["--games", str(games), "--out", str(out), "--seed", str(TINY_SEED),
            "--shard-games", str(shard_games), "--workers", "1"]


def test_killed_run_resumes_to_the_uninterrupted_dataset(tmp_path):
    games, shard_games = 20, 2
    out = tmp_path / "killed"
    args = _collect_command(out, games, shard_games)
    proc = subprocess.Popen([sys.executable, "-m", "rllib_pommer.collect", *args],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while not (out / "shard-000000.parquet").exists():
            assert proc.poll() is None and time.monotonic() < deadline, "no shard was written"
            time.sleep(0.005)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    survivors = sorted(out.glob(SHARD_GLOB))
    assert 1 <= len(survivors) < games // shard_games, "the kill came after the last shard"
    for path in survivors:
        shard, _ = read_meta(path)
        assert shard.read().num_rows == shard.metadata.num_rows
    assert main(args) == 0
    Collection(tmp_path / "whole", games, TINY_SEED, shard_games).run(workers=1)
    resumed = read_all(out)
    assert resumed.equals(read_all(tmp_path / "whole"))
    assert len(np.unique(row_keys(resumed), axis=0)) == resumed.num_rows
    assert sorted(p.name for p in out.iterdir()) == [p.name for p in sorted(out.glob(SHARD_GLOB))]


def test_rerun_keeps_finished_shards_and_clears_temporaries(tiny_dataset, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(tiny_dataset, out)
    kept, redone = out / "shard-000000.parquet", out / "shard-000001.parquet"
    kept_stamp = kept.stat().st_mtime_ns
    redone.unlink()
    (out / ".shard-000001.12345.tmp").write_bytes(b"half a shard")
    collection = _tiny(out, TINY_GAMES, TINY_SEED)
    assert collection.missing == [1]
    collection.run(workers=1)
    assert kept.stat().st_mtime_ns == kept_stamp
    assert sorted(p.name for p in out.iterdir()) == [kept.name, redone.name]
    assert read_all(out).equals(read_all(tiny_dataset))


def test_shards_of_another_dataset_are_refused(tiny_dataset):
    with pytest.raises(ValueError, match="shard-000000.parquet.*seed 7.*seed 8"):
        _tiny(tiny_dataset, TINY_GAMES, TINY_SEED + 1)
    with pytest.raises(ValueError, match="shard-000001.parquet.*games 3..5.*games 3..3"):
        _tiny(tiny_dataset, 4, TINY_SEED)
    with pytest.raises(ValueError, match="shard-000001.parquet.*no such shard"):
        _tiny(tiny_dataset, 3, TINY_SEED)
    assert _tiny(tiny_dataset, 9, TINY_SEED).missing == [2]  # grows


def test_cli_summary_and_bad_arguments(tmp_path, capsys):
    assert main(_collect_command(tmp_path / "cli", 2, 1)) == 0
    out = capsys.readouterr().out
    assert "2 shards, 2 games" in out and "bytes/sample" in out and "games/s" in out
    with pytest.raises(SystemExit):
        main(["--games", "0", "--out", str(tmp_path / "zero")])


def test_damaged_shards_are_played_again_on_resume(tiny_dataset, tmp_path, capsys):
    """A shard cut short and one with a corrupted data page (its footer intact) are found by the
    resume check, deleted and played again: the dataset comes back whole."""
    out = tmp_path / "damaged"
    shutil.copytree(tiny_dataset, out)
    cut, flipped = out / "shard-000000.parquet", out / "shard-000001.parquet"
    cut.write_bytes(cut.read_bytes()[: cut.stat().st_size // 2])
    maps = read_meta(flipped)[0].metadata.row_group(0).column(5)
    data = bytearray(flipped.read_bytes())
    middle = maps.data_page_offset + maps.total_compressed_size // 2
    data[middle:middle + 8] = bytes(b ^ 0xFF for b in data[middle:middle + 8])
    flipped.write_bytes(bytes(data))
    collection = _tiny(out, TINY_GAMES, TINY_SEED)
    assert collection.missing == [0, 1]
    assert "shard-000000.parquet: damaged" in capsys.readouterr().err
    collection.run(workers=1)
    assert read_all(out).equals(read_all(tiny_dataset))
