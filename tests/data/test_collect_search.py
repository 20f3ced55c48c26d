"""Search-expert collection: four search agents' decisions, the same whatever the shards, batch
or resume, named in the metadata, and never mixed with another expert's shards."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from rllib_pommer.agents.registry import make_agent
from rllib_pommer.collect import main
from rllib_pommer.data.collector import SEARCH_SHARD_GAMES, Collection, plan_shards
from rllib_pommer.data.dataset import open_dataset
from rllib_pommer.data.expert import SearchExpert, play_search_games
from rllib_pommer.data.schema import SHARD_KEY, encode, read_meta
from rllib_pommer.game.constants import TEAM_PRESET
from rllib_pommer.game.engine import Game
from rllib_pommer.game.seeding import game_seeds
from rllib_pommer.imitation.features import featurize

from .conftest import read_all

EXPERT, GAMES, SEED, SHARD = "search_fast", 4, 11, 2
EFFORT = "depth=1 horizon=10 recall=5"  # policies/search_fast.toml


@pytest.fixture(scope="module")
def search_dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("search")
    Collection(out, GAMES, SEED, SHARD, expert=EXPERT).run(workers=1)
    return out


def _keys(table) -> np.ndarray:
    return np.stack([table.column(k).to_numpy().astype(np.int64)
                     for k in ("game", "step_count", "agent_id")], 1)


def test_the_metadata_names_the_expert_and_its_effort(search_dataset, tiny_dataset):
    shard, meta = read_meta(search_dataset / "shard-000000.parquet")
    assert (meta.agents, meta.policy, meta.effort, meta.label_draws) == ("search", EXPERT,
                                                                         EFFORT, 0)
    assert meta.expert == f"{EXPERT} (search, {EFFORT})"
    assert not np.frombuffer(shard.read().column("action_counts").combine_chunks().buffers()[1],
                             np.uint8).any()
    simple = json.loads(read_meta(tiny_dataset / "shard-000000.parquet")[0]
                        .metadata.metadata[SHARD_KEY])
    assert "effort" not in simple and simple["agents"] == "simple"  # as before search shards


def test_same_games_whatever_the_shards_and_the_batch(search_dataset, tmp_path):
    Collection(tmp_path / "one", GAMES, SEED, GAMES, expert=EXPERT).run(workers=1)
    assert read_all(tmp_path / "one").equals(read_all(search_dataset))
    meta = plan_shards(GAMES, SEED, SHARD, expert=EXPERT)[1]
    effort = SearchExpert.resolve(EXPERT).effort
    one_slot = play_search_games(SEED, range(SHARD, GAMES), effort, batch_games=1)
    shard, _ = read_meta(search_dataset / "shard-000001.parquet")
    assert encode(one_slot, meta).replace_schema_metadata(None).equals(
        shard.read().replace_schema_metadata(None))


@pytest.mark.parametrize("game", [0, 3])
def test_rows_are_the_search_agents_decisions(search_dataset, game):
    """Replay game `game` with the single-game API and one catalogue search agent per seat,
    each reset from its seat's stream as the arena resets it: every recorded observation and
    action comes back, and every decision of every living agent is there."""
    obs_rows, action_rows, counts = next(
        open_dataset(search_dataset).iter_batches(10**6, shuffle=False))
    keys = _keys(read_all(search_dataset))
    row_of = {tuple(k): i for i, k in enumerate(keys)}
    board_seed, rngs = game_seeds(SEED, game)
    engine, agents = Game(TEAM_PRESET), [make_agent(EXPERT) for _ in range(4)]
    for seat, agent in enumerate(agents):
        agent.reset(seat, int(TEAM_PRESET.game_type), rngs[seat])
    obs, step, checked = engine.reset(board_seed), 0, 0
    while not engine.done:
        actions = [0] * 4
        for seat in np.flatnonzero(obs.alive[0]):
            actions[seat] = agents[seat].act(obs.select(seat))
            row = row_of.pop((game, step, seat))
            for name, expected in obs.select(seat)._asdict().items():
                assert np.array_equal(getattr(obs_rows, name)[row], expected), (step, seat, name)
            assert action_rows[row] == actions[seat], (step, seat)
            checked += 1
        obs, _, _, _ = engine.step(actions)
        step += 1
    assert checked > 100 and not [k for k in row_of if k[0] == game]
    assert not counts.any()
    assert featurize(obs_rows.select(slice(0, 8))).shape[1:] == (19, 11, 11)  # imitate's planes


def test_a_resumed_collection_is_the_uninterrupted_one(search_dataset, tmp_path):
    out = tmp_path / "resumed"
    shutil.copytree(search_dataset, out)
    (out / "shard-000001.parquet").unlink()
    (out / ".shard-000001.4242.tmp").write_bytes(b"half a shard")
    collection = Collection(out, GAMES, SEED, SHARD, expert=EXPERT)
    assert collection.missing == [1]
    collection.run(workers=1)
    assert sorted(p.name for p in out.iterdir()) == ["shard-000000.parquet",
                                                     "shard-000001.parquet"]
    assert read_all(out).equals(read_all(search_dataset))


@pytest.mark.parametrize("expert, other", [
    ("simple", "search_fast (search, depth=1 horizon=10 recall=5)"),
    ("search", "search_fast (search, depth=1 horizon=10 recall=5)"),
])
def test_another_experts_shards_are_refused(search_dataset, expert, other):
    with pytest.raises(ValueError) as refused:
        Collection(search_dataset, GAMES, SEED, SHARD, expert=expert)
    message = str(refused.value)
    assert "\n" not in message and "shard-000000.parquet" in message
    assert f"collected by expert {other}" in message
    assert f"this run's expert is {'simple' if expert == 'simple' else 'search (search, '}" \
        in message


def test_search_shards_are_refused_in_a_simple_dataset(tiny_dataset, capsys):
    args = ["--games", "6", "--out", str(tiny_dataset), "--seed", "7", "--shard-games", "3",
            "--expert", EXPERT, "--workers", "1"]
    assert main(args) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "shard-000000.parquet" in err[0]
    assert "collected by expert simple;" in err[0] and f"is {EXPERT} (search," in err[0]


@pytest.mark.parametrize("options, refusal", [
    (dict(expert="static"), "not a 'static' policy"),
    (dict(expert="search_action"), "without suffixes"),
    (dict(expert="no_such_policy"), "unknown policy"),
    (dict(expert="search", label_draws=8), "label-draws"),
])
def test_bad_search_settings_are_refused(options, refusal, tmp_path):
    with pytest.raises(ValueError, match=refusal):
        plan_shards(GAMES, SEED, SHARD, **options)


def test_cli_collects_search_games_in_small_shards(tmp_path, capsys):
    out = tmp_path / "cli"
    assert main(["--games", "1", "--out", str(out), "--seed", str(SEED), "--expert", EXPERT,
                 "--workers", "1"]) == 0
    printed = capsys.readouterr()
    assert "1 shards, 1 games" in printed.out and "games/s" in printed.out
    assert EXPERT in printed.err  # the progress bar names the expert
    _, meta = read_meta(out / "shard-000000.parquet")
    assert meta.shard_games == SEARCH_SHARD_GAMES and meta.policy == EXPERT
