"""A self-play league under prioritized matchmaking survives the command line's whole round trip:
`train --stop`, `--pack`, a move to another folder (as a fresh clone holds a committed run) and
`--resume` from another working directory. The league's state is its snapshot modules' (`born`
and `tally` beside pi) and the matchmaking book's (rl/league.py), so the test follows them from
the packed checkpoint to the resumed one: the filled slot keeps its birth and weights, the gate's
block counts on from where the packed checkpoint left it (a block spans many iterations here, so
a reset would show), the snapshot is a member, and plays, from the first resumed iteration, and
each member's record goes on from the packed one, iteration by iteration (a fresh book would
show: the records fade slowly here)."""

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest
import torch

from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.matchmaking import Record
from rllib_pommer.rl.league import MATCHMAKING_MODULE, Slot, members, next_slot
from rllib_pommer.runs.checkpoints import (
    MODULES_DIR,
    checkpoint_complete,
    checkpoint_iteration,
    load_checkpoint_net,
    read_module_state,
)

from .test_resume import REPO, _interrupt, _newest_leg, _results, _train, _wait_for
from .test_self_play import SELF_PLAY_SMOKE

# Suicide opponents alone: the learner wins nearly every (10-step) game, so the first block fills
# snapshot_0. With snapshot_0 playing, games last longer and an iteration holds fewer: the next
# block outlasts the stop, the pack and the resume several times over.
GATE_GAMES = 1000
LEAGUE_RESUME = (("num_envs_per_env_runner = 4\n",
                  "num_envs_per_env_runner = 4\ncheckpoint_every = 1\n"),
                 ("gate_games = 4\n", f"gate_games = {GATE_GAMES}\n"),
                 ('opponent = ["suicide", "static_action"]', 'opponent = ["suicide"]'),
                 ("gate_win = 0.5\n", 'gate_win = 0.5\nmatchmaking = "prioritized"\n'
                                      "priority_halflife = 5000\n"))


def _records(checkpoint, members_: list[str]) -> dict[str, Record]:
    """The matchmaking book as a checkpoint's learner holds it."""
    state = read_module_state(checkpoint / MODULES_DIR / MATCHMAKING_MODULE / "module_state.pkl")
    return {name: Record(*(float(n) for n in row))
            for name, row in zip(members_, state["results"], strict=True)}


def _reported(row: dict) -> dict[str, float]:
    return {name: entry["games"] for name, entry in row["matchmaking"].items()}


def _book(checkpoint, slot_ids) -> list[Slot]:
    """The league's slots as a checkpoint's learner holds them."""
    slots = []
    for slot_id in slot_ids:
        state = read_module_state(checkpoint / MODULES_DIR / slot_id / "module_state.pkl")
        wins, games = (int(n) for n in state["tally"])
        slots.append(Slot(slot_id, int(state["born"]), wins, games))
    return slots


def _filled_checkpoint(run, slot_ids) -> bool:
    for checkpoint in run.glob("*/checkpoint_*"):
        try:
            if checkpoint_complete(checkpoint) and _book(checkpoint, slot_ids)[0].filled:
                return True
        except (OSError, ValueError):  # rotated away by Tune while read
            continue
    return False


def _count(row: dict, key: str) -> int:
    value = row["env_runners"].get(key, 0)
    return 0 if value != value else int(value)  # NaN: none this iteration


def _command(out, *extra):
    return [sys.executable, "-m", "rllib_pommer.train", "--out", str(out), *extra]


def test_a_league_survives_stop_pack_move_and_resume(tmp_path, pi_weights):
    text = SELF_PLAY_SMOKE
    for old, new in LEAGUE_RESUME:
        assert old in text, old
        text = text.replace(old, new)
    curriculum = tmp_path / "league_resume.toml"
    curriculum.write_text(text)
    slot_ids = load_curriculum(curriculum).league.slot_ids()
    league_members = load_curriculum(curriculum).league_members()
    halflife = load_curriculum(curriculum).league.priority_halflife
    started_from = tmp_path / "first" / "weights" / "pi.pt"  # removed with the old place
    started_from.parent.mkdir(parents=True)
    shutil.copy(pi_weights, started_from)
    first = tmp_path / "first" / "run"
    process = subprocess.Popen(_train(first, started_from, "--curriculum", str(curriculum)),
                               cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               start_new_session=True)
    try:
        _wait_for(lambda: _filled_checkpoint(first, slot_ids), process, 240,
                  "a checkpoint with snapshot_0 filled")
        stop = subprocess.run(_command(first, "--stop"), cwd=REPO, capture_output=True,
                              text=True, timeout=300)
        assert stop.returncode == 0 and "stopped after PPO_" in stop.stdout, stop.stderr[-2000:]
        assert process.wait(timeout=60) == 130
    finally:
        if process.poll() is None:
            _interrupt(process)
    before = _results(first)  # every row of the first run; the pack keeps the last alone
    packed = subprocess.run(_command(first, "--pack"), cwd=REPO, capture_output=True, text=True,
                            timeout=120)
    assert packed.returncode == 0, packed.stderr[-2000:]
    (checkpoint,) = first.glob("*/checkpoint_*")
    iteration = checkpoint_iteration(checkpoint)
    book = _book(checkpoint, slot_ids)
    snapshot_pi = load_checkpoint_net(checkpoint, module="snapshot_0").state_dict()
    # The packed book is the one the first run reported: snapshot_0 born at the lifetime
    # episode count of the iteration that filled it, the gate in the middle of its next block.
    fill = [r for r in before if r["training_iteration"] <= iteration
            and r["league"]["filled"] == "snapshot_0"]
    assert book[0].born == fill[-1]["env_runners"]["num_episodes_lifetime"] > 0
    (at_checkpoint,) = [r for r in before if r["training_iteration"] == iteration]
    block = next_slot(book)
    assert block.module_id == "snapshot_1" and not book[1].filled
    assert 0 < block.games == at_checkpoint["league"]["gate_games"] < GATE_GAMES
    assert at_checkpoint["league"]["members"] == list(members(book)) == ["snapshot_0"]
    records = _records(checkpoint, league_members)  # the book the first run reported last
    assert {name: records[name].games for name in _reported(at_checkpoint)} == pytest.approx(
        _reported(at_checkpoint))
    assert records["snapshot_0"].games > 0 and records["suicide"].games > 0

    moved = tmp_path / "clone" / "campaign" / "run"
    shutil.copytree(first, moved)
    shutil.rmtree(tmp_path / "first")  # nothing may point back to the old place
    resumed_log = tmp_path / "resumed.log"
    with open(resumed_log, "wb") as log:  # its own curriculum, noted in the run
        process = subprocess.Popen(_command(moved, "--resume"), cwd=tmp_path,
                                   stdout=subprocess.DEVNULL, stderr=log,
                                   start_new_session=True)
    try:
        _wait_for(lambda: [c for c in moved.glob("*/checkpoint_*")
                           if c.parent.name != checkpoint.parent.name
                           and checkpoint_complete(c)], process, 240,
                  "a checkpoint after the resume")
    finally:
        _interrupt(process)
    trial = _newest_leg(moved)  # the resume's own trial
    resumed = sorted((r for r in _results(moved)
                      if r["iterations_since_restore"] < r["training_iteration"]),
                     key=lambda r: r["training_iteration"])
    assert resumed, resumed_log.read_text()[-3000:]
    assert resumed[0]["training_iteration"] == iteration + 1
    # snapshot_0 is a member, and plays, from the first resumed iteration
    assert resumed[0]["env_runners"]["num_module_steps_sampled"].get("snapshot_0", 0) > 0
    # The gate's block counts on from the packed checkpoint's, iteration by iteration.
    wins, games, tally_at = block.wins, block.games, {}
    for row in resumed:
        assert row["league"]["snapshots"] == 1 and row["league"]["members"] == ["snapshot_0"]
        wins += row["env_runners"]["league_wins"]
        games += row["env_runners"]["league_games"]
        assert games < GATE_GAMES, "the block ended after the resume: raise GATE_GAMES"
        assert row["league"]["gate_games"] == games, (row["training_iteration"], block)
        tally_at[row["training_iteration"]] = (wins, games)
        new = {}  # the book counts on: each member's record plus this iteration's games
        for name in ("suicide", "snapshot_0"):
            played, won, lost = (_count(row, f"league_{key}_vs_{name}")
                                 for key in ("games", "wins", "losses"))
            new[name] = records[name].add(won, lost, played - won - lost, halflife)
        records = {**records, **new}
        assert _reported(row) == pytest.approx({name: records[name].games for name in new})
    newest = max((c for c in trial.glob("checkpoint_*") if checkpoint_complete(c)),
                 key=checkpoint_iteration)
    assert checkpoint_iteration(newest) > iteration
    wins, games = tally_at[checkpoint_iteration(newest)]
    assert _book(newest, slot_ids) == [book[0], Slot("snapshot_1", -1, wins, games)]
    kept_pi = load_checkpoint_net(newest, module="snapshot_0").state_dict()
    assert all(torch.equal(kept_pi[key], value) for key, value in snapshot_pi.items())
