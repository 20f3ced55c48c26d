"""Search-expert collection: four search agents' decisions, the same whatever the shards, batch
or resume, named in the metadata, and never mixed with another expert's shards."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from rllib_pommer.agents.registry import make_agent
from rllib_pommer.collect import main
from rllib_pommer.data.collector import SEARCH_SHARD_GAMES, Collection, Dagger, plan_shards
from rllib_pommer.data.dataset import open_dataset
from rllib_pommer.data.expert import SearchExpert, play_search_games
from rllib_pommer.data.schema import SHARD_KEY, encode, read_meta
from rllib_pommer.imitation.features import featurize

from .conftest import read_all, replay_against_rows

EXPERT, GAMES, SEED, SHARD, DRAWS = "search_fast", 4, 11, 2, 8
EFFORT = "depth=1 horizon=10 recall=5"  # policies/search_fast.toml


def _collection(out, games=GAMES, shard_games=SHARD, expert=EXPERT) -> Collection:
    return Collection(out, games, SEED, shard_games, DRAWS, expert=expert)


@pytest.fixture(scope="module")
def search_dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("search")
    _collection(out).run(workers=1)
    return out


def test_the_metadata_names_the_expert_and_its_effort(search_dataset, tiny_dataset):
    _, meta = read_meta(search_dataset / "shard-000000.parquet")
    assert (meta.agents, meta.policy, meta.effort, meta.label_draws) == ("search", EXPERT,
                                                                         EFFORT, DRAWS)
    assert meta.expert == f"{EXPERT} (search, {EFFORT})"
    simple = json.loads(read_meta(tiny_dataset / "shard-000000.parquet")[0]
                        .metadata.metadata[SHARD_KEY])
    assert "effort" not in simple and simple["agents"] == "simple"  # as before search shards


def test_same_games_whatever_the_shards_and_the_batch(search_dataset, tmp_path):
    _collection(tmp_path / "one", shard_games=GAMES).run(workers=1)
    assert read_all(tmp_path / "one").equals(read_all(search_dataset))
    meta = plan_shards(GAMES, SEED, SHARD, DRAWS, expert=EXPERT)[1]
    effort = SearchExpert.resolve(EXPERT).effort
    one_slot = play_search_games(SEED, range(SHARD, GAMES), effort, batch_games=1,
                                 label_draws=DRAWS)
    shard, _ = read_meta(search_dataset / "shard-000001.parquet")
    assert encode(one_slot, meta).replace_schema_metadata(None).equals(
        shard.read().replace_schema_metadata(None))


@pytest.mark.parametrize("game", [0, 3])
def test_rows_are_the_search_agents_decisions(search_dataset, game):
    """Replay game `game` with the single-game API and one catalogue search agent per seat,
    each reset from its seat's stream as the arena resets it: every recorded observation and
    action comes back, and every decision of every living agent is there."""
    checked, unmatched = replay_against_rows(search_dataset, SEED, game,
                                             [make_agent(EXPERT) for _ in range(4)])
    assert checked > 100 and not unmatched
    obs_rows, _, counts = next(open_dataset(search_dataset).iter_batches(10**6, shuffle=False))
    assert (counts.sum(1) == DRAWS).all()
    assert featurize(obs_rows.select(slice(0, 8))).shape[1:] == (19, 11, 11)  # imitate's planes


def test_a_resumed_collection_is_the_uninterrupted_one(search_dataset, tmp_path):
    out = tmp_path / "resumed"
    shutil.copytree(search_dataset, out)
    (out / "shard-000001.parquet").unlink()
    (out / ".shard-000001.4242.tmp").write_bytes(b"half a shard")
    collection = _collection(out)
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
        _collection(search_dataset, expert=expert)
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


def _no_actor(policy):
    raise AssertionError("never asked for")


@pytest.mark.parametrize("options, refusal", [
    (dict(expert="static"), "not a 'static' policy"),
    (dict(expert="search_action"), "without suffixes"),
    (dict(expert="no_such_policy"), "unknown policy"),
    (dict(expert="search", label_draws=8, dagger=Dagger("clone", ("simple",), _no_actor)),
     "DAgger data are labelled by SimpleAgent"),
])
def test_bad_search_settings_are_refused(options, refusal):
    with pytest.raises(ValueError, match=refusal):
        plan_shards(GAMES, SEED, SHARD, **options)


def test_label_draws_leave_the_games_alone_and_count_the_tie_breaks():
    """With or without counts the same games are played. Each row's counts add up to the draws;
    the played action is one more draw of the same tie-break, so it is nearly always among them,
    and most decisions are unanimous (the draw decides only between values within 1)."""
    effort = SearchExpert.resolve(EXPERT).effort
    plain = play_search_games(SEED, range(2), effort)
    soft = play_search_games(SEED, range(2), effort, label_draws=DRAWS)
    assert np.array_equal(plain.action, soft.action) and not plain.action_counts.any()
    assert np.array_equal(plain.obs.board, soft.obs.board)
    assert (soft.action_counts.sum(1) == DRAWS).all()
    played_share = soft.action_counts[np.arange(len(soft.action)), soft.action].mean() / DRAWS
    undecided = (soft.action_counts.max(1) < DRAWS).mean()
    assert 0.7 < played_share < 0.99 and 0.02 < undecided < 0.6, (played_share, undecided)
    again = play_search_games(SEED, range(2), effort, label_draws=DRAWS)
    assert np.array_equal(again.action_counts, soft.action_counts)


def test_cli_collects_search_games_in_small_shards(tmp_path, capsys):
    out = tmp_path / "cli"
    assert main(["--games", "1", "--out", str(out), "--seed", str(SEED), "--expert", EXPERT,
                 "--workers", "1"]) == 0
    printed = capsys.readouterr()
    assert "1 shards, 1 games" in printed.out and "games/s" in printed.out
    assert EXPERT in printed.err  # the progress bar names the expert
    _, meta = read_meta(out / "shard-000000.parquet")
    assert meta.shard_games == SEARCH_SHARD_GAMES and meta.policy == EXPERT


def test_imitate_trains_on_search_data_unchanged(search_dataset, tmp_path):
    """Behaviour cloning reads the search expert's shards as it reads SimpleAgent's: a few
    batches against the soft targets lower the loss below an untrained net's log(6)."""
    from rllib_pommer.imitation.bc import BCConfig, train  # torch

    cfg = BCConfig(data=[search_dataset], out=tmp_path / "clone", epochs=3, batch_size=64,
                   lr=3e-3, dropout=0.0, val_fraction=0.25, threads=1, max_val_batches=None)
    metrics = train(cfg)
    assert metrics["train_samples"] > 0 and metrics["validation_samples"] > 0
    assert metrics["validation_loss"] < np.log(6) - 0.1


def test_a_clone_names_the_expert_it_copies(search_dataset, tiny_dataset, tmp_path):
    from rllib_pommer.imitate import experts

    assert experts([tiny_dataset, search_dataset]) == (
        f"SimpleAgent ({tiny_dataset.name}), the search agent {EXPERT} ({search_dataset.name})")
