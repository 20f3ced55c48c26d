"""Prioritized matchmaking: the rule (records that fade, weights with a floor, turns in
proportion without randomness), the curriculum's keys, and a league that spends its games on the
member the learner fails to beat, with its book in the checkpoint; and a league's exploiter,
trained against the learner alone, whose pi joins the league when it wins a block."""

from __future__ import annotations

import dataclasses
import pickle
import shutil
from collections import Counter
from types import SimpleNamespace

import pytest
import torch
from ray.rllib.algorithms.algorithm import Algorithm

from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.mapping import SeatMapping
from rllib_pommer.curriculum.matchmaking import Record, WeightedTurns, priority, shares
from rllib_pommer.curriculum.names import EXPLOITER, LEARNER
from rllib_pommer.rl.config import build_config
from rllib_pommer.rl.league import MATCHMAKING_MODULE, exploiter_step

from .test_self_play import SELF_PLAY_SMOKE, _same

PRIORITIZED_SMOKE = SELF_PLAY_SMOKE.replace(
    "gate_win = 0.5\n", 'gate_win = 0.5\nmatchmaking = "prioritized"\npriority_halflife = 50\n')


def test_a_record_fades_by_half_per_halflife_of_new_games():
    record = Record().add(8, 2, 0, halflife=10)
    assert (record.wins, record.losses, record.ties) == (8, 2, 0)
    assert record.win_rate == pytest.approx(8 / 11)
    later = record.add(0, 0, 10, halflife=10)  # 10 new games: the old ones count half
    assert (later.wins, later.losses, later.ties) == pytest.approx((4, 1, 10))
    assert Record().win_rate == 0.0  # never met: unbeaten


def test_weights_favour_the_members_the_learner_fails_to_beat_with_a_floor():
    beaten, tied, unseen = Record(wins=99), Record(ties=99), Record()
    assert priority(beaten, power=2, floor=0.1) == 0.1  # floor: (1 - 0.99) ** 2 is below it
    assert priority(tied, power=2, floor=0.1) == 1.0  # a tie is a failure
    assert priority(unseen, power=2, floor=0.1) == 1.0
    half = Record(wins=50, losses=49)
    assert priority(half, power=2, floor=0.1) == pytest.approx(0.25)
    assert shares([beaten, tied, half], 2, 0.1) == pytest.approx([0.1 / 1.35, 1 / 1.35,
                                                                  0.25 / 1.35])


def test_turns_follow_the_weights_in_proportion_without_randomness():
    turns = WeightedTurns(3)
    played = [turns.next((3.0, 1.0, 0.5)) for _ in range(90)]
    assert Counter(played) == {0: 60, 1: 20, 2: 10}
    for end in range(1, 91):  # every stretch from the start within one turn of its share
        counts = Counter(played[:end])
        assert all(abs(counts[i] - end * w / 4.5) < 1 for i, w in enumerate((3, 1, 0.5)))
    assert [WeightedTurns(2).next((1.0, 1.0)) for _ in range(1)] == [0]
    even = WeightedTurns(3)
    assert [even.next((1.0,) * 3) for _ in range(6)] == [0, 1, 2, 0, 1, 2]  # round robin


def test_a_weighted_league_gives_whole_seat_cycles_by_weight():
    mapping = SeatMapping(0, "suicide", ("static", "simple"), weights=(3.0, 1.0))
    played = []
    for n in range(32):
        episode = SimpleNamespace(id_=f"e{n}")
        modules = [mapping(agent, episode) for agent in range(4)]
        seat = modules.index(LEARNER)
        played.append((seat, modules[(seat + 1) % 4]))
    assert [seat for seat, _ in played] == [0, 1, 2, 3] * 8
    cycles = [{name for _, name in played[i:i + 4]} for i in range(0, 32, 4)]
    assert all(len(names) == 1 for names in cycles)  # one opponent a whole seat cycle
    assert Counter(names.pop() for names in cycles) == {"static": 6, "simple": 2}
    mapping.weights = (1.0, 3.0)  # the callback's update, in place: the cycle goes on
    episode = SimpleNamespace(id_="e32")
    assert [mapping(agent, episode) for agent in range(4)].index(LEARNER) == 0
    old = pickle.loads(pickle.dumps(SeatMapping(0, "suicide", ("a", "b"))))
    del old.__dict__["weights"], old.__dict__["_turns"], old.__dict__["_weighted"]
    revived = pickle.loads(pickle.dumps(old))  # pickled before matchmaking: plays in turn
    assert revived.weights is None and revived.opponent_of("x") == "a"


def test_matchmaking_keys_are_checked(tmp_path):
    path = tmp_path / "c.toml"
    for old, new, words in (('"prioritized"', '"hardest"', "matchmaking 'hardest' is not one"),
                            ("priority_halflife = 50", "priority_halflife = 0",
                             "priority_halflife must be a positive integer"),
                            ("priority_halflife = 50", "priority_floor = 0",
                             r"priority_floor must be in \(0, 1\]")):
        path.write_text(PRIORITIZED_SMOKE.replace(old, new))
        with pytest.raises(ValueError, match=words):
            load_curriculum(path)
    path.write_text(PRIORITIZED_SMOKE)
    curriculum = load_curriculum(path)
    assert curriculum.league.prioritized and curriculum.league.priority_halflife == 50
    assert curriculum.league_members() == ["suicide", "static_action", "snapshot_0",
                                           "snapshot_1"]


def _games(runners: dict, name: str) -> int:
    """An iteration's games against `name` (a sum over none is NaN in RLlib's results)."""
    games = runners.get(f"league_games_vs_{name}", 0)
    return 0 if games != games else int(games)


def test_a_prioritized_league_plays_most_whom_it_fails_to_beat_and_keeps_its_book(
        ray_session, pi_weights, tmp_path):
    path = tmp_path / "prioritized.toml"
    path.write_text(PRIORITIZED_SMOKE)
    curriculum = load_curriculum(path)
    algo = build_config(curriculum, pi_weights=pi_weights).build_algo()
    try:
        learner = algo.learner_group._learner
        results = [algo.train() for _ in range(4)]
        # suicide loses every game; static_action, behind the filter and 40 steps, is tied
        runners = results[-1]["env_runners"]
        shares_now = results[-1]["matchmaking"]
        assert shares_now["static_action"]["share"] > 3 * shares_now["suicide"]["share"]
        assert shares_now["suicide"]["win_rate"] > 0.8 > shares_now["static_action"]["win_rate"]
        played = Counter()
        for result in results[1:]:
            for name in ("suicide", "static_action"):
                played[name] += _games(result["env_runners"], name)
        assert played["static_action"] > played["suicide"], played
        assert runners["league_games"] == sum(
            _games(runners, name) for name in curriculum.league_members())
        # the runner's mapping carries the weights the book gives
        mapping = algo.env_runner.config.policy_mapping_fn
        records = learner.module[MATCHMAKING_MODULE].records()
        league = curriculum.league
        assert mapping.weights == tuple(priority(records[name], league.priority_power,
                                                 league.priority_floor)
                                        for name in mapping.opponent)
        assert {name: records[name].games for name in mapping.opponent} == pytest.approx(
            {name: shares_now[name]["games"] for name in mapping.opponent})
        checkpoint = algo.save_to_path(str(tmp_path / "checkpoint"))
    finally:
        algo.stop()
    moved = tmp_path / "elsewhere" / "checkpoint"
    shutil.copytree(checkpoint, moved)
    shutil.rmtree(checkpoint)
    restored = Algorithm.from_checkpoint(str(moved))
    try:
        book = restored.learner_group._learner.module[MATCHMAKING_MODULE].records()
        assert book == records
        assert restored.env_runner.config.policy_mapping_fn.weights == mapping.weights
    finally:
        restored.stop()


EXPLOITER_SMOKE = PRIORITIZED_SMOKE.replace(
    "priority_halflife = 50\n", "priority_halflife = 50\nexploiter = true\n"
    "exploiter_gate_games = 100000\nexploiter_gate_win = 0.5\n").replace(
    'opponent = ["suicide", "static_action"]', 'opponent = ["suicide"]').replace(
    "gate_games = 4\n", "gate_games = 100000\n")


def test_an_exploiter_trains_against_the_learner_alone_and_its_pi_joins_the_league(
        ray_session, pi_weights, tmp_path):
    path = tmp_path / "exploiter.toml"
    path.write_text(EXPLOITER_SMOKE)
    curriculum = load_curriculum(path)
    assert curriculum.league_members() == ["suicide", EXPLOITER, "snapshot_0", "snapshot_1"]
    algo = build_config(curriculum, pi_weights=pi_weights).build_algo()
    try:
        learner = algo.learner_group._learner
        exploiter, main = learner.module[EXPLOITER], learner.module[LEARNER]
        start = {k: v.clone() for k, v in exploiter.pi.state_dict().items()}
        assert _same(exploiter.pi, main.pi)  # the same start
        result = algo.train()
        played = _games(result["env_runners"], EXPLOITER)
        assert played > 0 and result["league"]["exploiter"]["gate_games"] in (played, 0)
        assert EXPLOITER in algo.env_runner.config.policy_mapping_fn.opponent
        assert not all(torch.equal(exploiter.pi.state_dict()[k], v) for k, v in start.items())
        assert not _same(exploiter.pi, main.pi)  # each trains on its own rows
        # a block won at the gate's rate: its pi joins the league, and it starts again
        trained_exploiter = {k: v.clone() for k, v in exploiter.pi.state_dict().items()}
        book = learner.module[MATCHMAKING_MODULE]
        book.exploiter[:] = 0
        league = dataclasses.replace(curriculum.league, exploiter_gate_games=6)
        assert exploiter_step(learner, league, 2, 5, 99) is None  # the block is not full
        slot = exploiter_step(learner, league, 2, 1, 100)
        assert slot == "snapshot_0" and book.exploiter.tolist() == [0, 0]
        assert all(torch.equal(learner.module[slot].pi.state_dict()[k], v)
                   for k, v in trained_exploiter.items())
        assert int(learner.module[slot].born) == 100
        assert _same(exploiter.pi, main.pi) and _same(exploiter.vf, main.vf)
        assert exploiter_step(learner, league, 2, 6, 101) is None  # lost: no slot
        assert not learner.module["snapshot_1"].slot("snapshot_1").filled
    finally:
        algo.stop()
