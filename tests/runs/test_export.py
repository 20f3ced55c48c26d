"""`train --out RUN --export policies/NAME`: a run's learner shipped as `imitation` is, a plain
state_dict and a policy file that the arena plays, never over an existing policy, with a model
card drawn from the run up to the exported checkpoint; `report --card` redraws it with results."""

from __future__ import annotations

import csv
import hashlib
import json
import pickle
import re
import shutil
import subprocess
from collections import OrderedDict
from pathlib import Path

import numpy as np
import pytest
import torch

from rllib_pommer.arena.match import MatchSpec, play_match
from rllib_pommer.curriculum.curriculum import PI_START_KEY, RUN_CURRICULUM_FILE
from rllib_pommer.data.collector import Collection, Dagger
from rllib_pommer.game.constants import NUM_AGENTS
from rllib_pommer.game.engine import Games
from rllib_pommer.imitation.learned import greedy_actor
from rllib_pommer.imitation.network import PommerNet
from rllib_pommer.report import main as report
from rllib_pommer.runs.checkpoints import (
    ALGORITHM_STATE,
    MODULE_STATE,
    checkpoint_complete,
    checkpoint_iteration,
    latest_checkpoint,
    load_checkpoint_net,
)
from rllib_pommer.runs.export import packed_commits
from rllib_pommer.runs.history import (
    HISTORY_FILE,
    POLICY_HISTORY_DIR,
    exported_training,
    read_trial,
)
from rllib_pommer.train import main

REPO = Path(__file__).resolve().parents[2]
COLUMNS = ("training_iteration", "time_total_s", "env_runners/num_env_steps_sampled_lifetime",
           "env_runners/num_episodes_lifetime", "env_runners/module_episode_returns_mean/learner",
           "curriculum/iteration_stage_name", "curriculum/iteration_reward")


def _fake_run(run: Path, pi: PommerNet, iterations: int = 4, checkpoint_at: int = 3) -> Path:
    """A run folder as `train` leaves it, with the smoke curriculum: `iterations` result rows,
    an empty older checkpoint and a newer one taken at iteration `checkpoint_at` holding `pi` (and
    a value net) as RLlib saves them."""
    trial = run / "PPO_pommerman_team_00000"
    state = OrderedDict((f"pi.{k}", v.numpy()) for k, v in pi.state_dict().items())
    state |= {f"vf.{k}": torch.full_like(v, 0.5).numpy()
              for k, v in PommerNet(1).state_dict().items()}
    for number, iteration in ((1, 1), (2, checkpoint_at)):
        path = trial / f"checkpoint_00000{number}"
        (path / MODULE_STATE).parent.mkdir(parents=True)
        with (path / MODULE_STATE).open("wb") as f:
            pickle.dump(state if number == 2 else OrderedDict(), f)
        with (path / ALGORITHM_STATE).open("wb") as f:  # numpy scalars, as RLlib's metrics hold
            pickle.dump({"training_iteration": iteration,
                         "metrics_logger": {"stats": {"x": np.float64(1.5)}}}, f)
        (path / "rllib_checkpoint.json").write_text('{"type": "Algorithm"}')
    (trial / "params.json").write_text(json.dumps(
        {"callbacks": "functools.partial(<class 'rllib_pommer.rl.callbacks.CurriculumCallback'>, "
                      "Curriculum(name='smoke', "
                      "path=PosixPath('/elsewhere/curriculum/smoke.toml'), ...)"}))
    with open(trial / "progress.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(COLUMNS)
        for k in range(1, iterations + 1):
            writer.writerow([k, 10.0 * k, 400 * k, 6 * k, 0.1 * k,
                             "warmup" if k <= 2 else "static", "shaped"])
    return trial


def test_export_writes_a_plain_state_dict_a_policy_the_arena_plays_and_a_card(tmp_path, capsys):
    torch.manual_seed(3)
    pi = PommerNet()
    _fake_run(tmp_path / "run", pi)
    target = tmp_path / "policies" / "ppo"
    assert main(["--out", str(tmp_path / "run"), "--export", str(target)]) == 0
    weights = torch.load(target / "pi.pt", weights_only=True)
    assert weights.keys() == pi.state_dict().keys()
    assert all(torch.equal(weights[k], v) for k, v in pi.state_dict().items())
    vf = torch.load(target / "vf.pt", weights_only=True)  # for a run that continues this one
    assert vf.keys() == PommerNet(1).state_dict().keys()
    assert all(torch.equal(v, torch.full_like(v, 0.5)) for v in vf.values())
    policy_file = target.with_suffix(".toml")
    assert 'weights = "ppo/pi.pt"' in policy_file.read_text()
    assert "checkpoint_000002" in policy_file.read_text()
    records = list(play_match(MatchSpec(team=str(policy_file), vs="static", games=2), workers=1))
    assert len(records) == 2

    # the card: training up to the checkpoint's iteration (3), not the row after it
    source = json.loads((target / "source.json").read_text())
    assert (source["iteration"], source["curriculum"]["name"]) == (3, "smoke")
    assert [s["name"] for s in source["curriculum"]["stages"]] == ["warmup", "static"]
    card = (target / "MODEL_CARD.md").read_text()
    assert "18 of 24 games" in card and "1,200" in card  # iteration 3: 6 x 3 games, 400 x 3 steps
    assert "| run | warmup | 2 | 12 |" in card and "| run | static | 1 | 6 |" in card
    assert (target / "fig3_training.png").stat().st_size > 0
    assert "Not played yet" in card

    capsys.readouterr()
    assert main(["--out", str(tmp_path / "run"), "--export", str(target)]) == 2
    assert f"{target / 'pi.pt'} exists" in capsys.readouterr().err


def test_a_stage_checkpoint_exports_with_its_runs_rows(tmp_path):
    trial = _fake_run(tmp_path / "run", PommerNet())
    shutil.copytree(trial / "checkpoint_000002", tmp_path / "run" / "stages" / "2-static")
    target = tmp_path / "ppo"
    assert main(["--out", str(tmp_path / "run" / "stages" / "2-static"),
                 "--export", str(target)]) == 0
    source = json.loads((target / "source.json").read_text())
    assert (source["checkpoint"], source["trial"], source["iteration"]) == (
        "stages/2-static", trial.name, 3)
    assert "18 of 24 games" in (target / "MODEL_CARD.md").read_text()


def test_report_card_adds_the_results_and_keeps_notes(tmp_path, capsys):
    _fake_run(tmp_path / "run", PommerNet())
    target = tmp_path / "ppo"
    assert main(["--out", str(tmp_path / "run"), "--export", str(target)]) == 0
    (target / "NOTES.md").write_text("Written by a person.\n")
    records = tmp_path / "ppo+action__vs__static.jsonl"
    with records.open("w") as f:
        for game, result in enumerate(("win", "win", "loss", "tie")):
            f.write(json.dumps({"game": game, "seats_a": [0, 2], "result": result, "team": "ppo",
                                "vs": "static", "filters": ["action"]}) + "\n")
    assert report(["--card", str(target), str(records)]) == 0
    card = (target / "MODEL_CARD.md").read_text()
    assert "Table 3: PPO team" in card and "0.500 / 0.250 / 0.250 (n=4)" in card
    assert card.rstrip().endswith("Written by a person.")
    assert "Not played yet" not in card
    capsys.readouterr()
    assert report(["--card", str(target), str(tmp_path / "run")]) == 2
    assert "record files only" in capsys.readouterr().err


def test_a_chosen_checkpoint_says_why_instead_of_training_goes_on(tmp_path):
    _fake_run(tmp_path / "run", PommerNet())
    target = tmp_path / "ppo"
    assert main(["--out", str(tmp_path / "run"), "--export", str(target)]) == 0
    assert "training goes on" in (target / "MODEL_CARD.md").read_text()
    source = json.loads((target / "source.json").read_text())
    (target / "source.json").write_text(json.dumps({**source, "chosen": "the last healthy one"}))
    assert report(["--card", str(target)]) == 0
    card = (target / "MODEL_CARD.md").read_text()
    assert "chosen over the run's end**: the last healthy one" in card
    assert "training goes on" not in card


def test_the_card_names_the_shipped_policy_pi_started_from(tmp_path):
    """pi at the end of the frozen warm-up is pi as the run began: the shipped policy with those
    weights is named, and a start that matches none is not."""
    imitation_v2 = PommerNet()
    imitation_v2.load_state_dict(torch.load(REPO / "policies/imitation_v2/pi.pt",
                                            weights_only=True))
    for run, start, expected in (("from_v2", imitation_v2, "imitation_v2"),
                                 ("from_elsewhere", PommerNet(), None)):
        trial = _fake_run(tmp_path / run, start)
        shutil.copytree(trial / "checkpoint_000002", tmp_path / run / "stages" / "1-warmup")
        target = tmp_path / f"{run}_policy"
        assert main(["--out", str(tmp_path / run), "--export", str(target)]) == 0
        assert json.loads((target / "source.json").read_text())["pi_start"] == expected
        card = (target / "MODEL_CARD.md").read_text()
        assert ("pi started from `imitation_v2`" in card) == (expected is not None)
        assert ("pi started from" in card) == (expected is not None)


def test_a_run_that_noted_the_digest_of_its_start_names_that_policy(tmp_path):
    """A run whose first stage trains pi (no frozen warm-up to compare) proves its start by the
    digest of the weights file it began with, noted when it started: the policy whose weights
    have that digest is named whatever pi became, and a digest no policy has names none."""
    ppo = hashlib.sha256((REPO / "policies/ppo/pi.pt").read_bytes()).hexdigest()
    for run, digest, expected in (("from_ppo", ppo, "ppo"), ("from_elsewhere", "0" * 64, None)):
        _fake_run(tmp_path / run, PommerNet())  # pi trained away from any start
        (tmp_path / run / RUN_CURRICULUM_FILE).write_text(json.dumps(
            {"curriculum": "smoke", "name": "smoke", PI_START_KEY: digest}))
        target = tmp_path / f"{run}_policy"
        assert main(["--out", str(tmp_path / run), "--export", str(target)]) == 0
        assert json.loads((target / "source.json").read_text())["pi_start"] == expected


def test_the_card_counts_the_games_from_the_imitation_clone_through_the_lineage(tmp_path):
    """A run that starts from `ppo` (itself trained from the clone `imitation_v2`) counts the
    games of both runs: the budget the paper's 100,000 games are set against."""
    ppo = PommerNet()
    ppo.load_state_dict(torch.load(REPO / "policies/ppo/pi.pt", weights_only=True))
    trial = _fake_run(tmp_path / "run", ppo)
    shutil.copytree(trial / "checkpoint_000002", tmp_path / "run" / "stages" / "1-warmup")
    target = tmp_path / "policy"
    assert main(["--out", str(tmp_path / "run"), "--export", str(target)]) == 0
    _, ppo_training = exported_training(REPO / "policies/ppo")
    ppo_games = sum(stage.episodes for stage in ppo_training.stages)
    assert ppo_games > 0
    source = json.loads((target / "source.json").read_text())
    assert source["lineage"] == [{"policy": "imitation_v2", "games": 0},
                                 {"policy": "ppo", "games": ppo_games}]
    card = (target / "MODEL_CARD.md").read_text()
    assert (f"games counted from the imitation clone `imitation_v2`: {ppo_games:,} as `ppo` + "
            f"18 in this run = **{ppo_games + 18:,}**") in card  # 6 games an iteration, to 3


def test_export_names_what_is_missing(tmp_path, capsys):
    trial = _fake_run(tmp_path / "run", PommerNet())
    (trial / "params.json").write_text("{}")
    assert main(["--out", str(tmp_path / "run"), "--export", str(tmp_path / "ppo")]) == 2
    assert "params.json: names no curriculum" in capsys.readouterr().err
    with (trial / "checkpoint_000002" / ALGORITHM_STATE).open("wb") as f:
        pickle.dump({"training_iteration": 9}, f)
    assert main(["--out", str(tmp_path / "run"), "--export", str(tmp_path / "ppo")]) == 2
    assert "no result row for iteration 9, where checkpoint_000002" in capsys.readouterr().err
    (trial / "checkpoint_000002" / ALGORITHM_STATE).write_bytes(pickle.dumps({"other": 1}))
    with pytest.raises(ValueError, match="algorithm_state.pkl: no training_iteration"):
        checkpoint_iteration(trial / "checkpoint_000002")


def test_a_checkpoint_not_whole_is_never_the_newest(tmp_path):
    """A run killed while Tune copied a checkpoint in leaves a newer folder without all of it:
    the newest whole one is taken (by export, the arena and pack)."""
    trial = _fake_run(tmp_path / "run", PommerNet())
    whole = trial / "checkpoint_000002"
    assert latest_checkpoint(trial) == whole
    for cut in ("module_state", "metadata", "algorithm_state"):
        newer = trial / "checkpoint_000003"
        shutil.copytree(whole, newer)
        with (newer / ALGORITHM_STATE).open("wb") as f:
            pickle.dump({"training_iteration": 99}, f)
        assert latest_checkpoint(trial) == newer  # whole, it would be the newest
        if cut == "module_state":
            data = (newer / MODULE_STATE).read_bytes()
            (newer / MODULE_STATE).write_bytes(data[: len(data) // 2])
        elif cut == "metadata":
            (newer / "rllib_checkpoint.json").unlink()
        else:
            (newer / ALGORITHM_STATE).write_bytes(b"")
        assert not checkpoint_complete(newer)
        assert latest_checkpoint(trial) == whole, cut
        shutil.rmtree(newer)


def test_the_committed_campaign_exports_to_its_checkpoint(tmp_path, committed_campaign):
    """The project's own run: the card's figures are the history's at the checkpoint."""
    target = tmp_path / "ppo"
    assert main(["--out", str(committed_campaign), "--export", str(target)]) == 0
    checkpoint = latest_checkpoint(committed_campaign)
    iteration = checkpoint_iteration(checkpoint)
    row = next(r for r in read_trial(checkpoint.parent).rows
               if int(float(r["training_iteration"])) == iteration)
    games = int(float(row["env_runners/num_episodes_lifetime"]))
    card = (target / "MODEL_CARD.md").read_text()
    assert re.search(rf"{games:,} of 100,000 games", card)
    assert f"iteration {iteration:,}" in card
    assert "pi started from `imitation_v2`" in card  # the soft-target clone, before DAgger
    kept = read_trial(target / POLICY_HISTORY_DIR / "paper").rows
    assert int(float(kept[-1]["training_iteration"])) == iteration
    net = load_checkpoint_net(checkpoint)
    weights = torch.load(target / "pi.pt", weights_only=True)
    assert all(torch.equal(weights[k], v) for k, v in net.state_dict().items())


def test_the_card_lists_the_packs_the_exported_rows_came_through(tmp_path):
    """A run packed at iteration 2 (a row 3 logged after its checkpoint), given a note, trained
    on to a collapse packed at 5, then set back to the first pack and trained again to 4: the
    policy came through the first and last packs only, and the note's commit packed nothing."""
    run = tmp_path / "campaign" / "run"
    trial = run / "PPO_pommerman_team_00000"

    def git(*args):
        subprocess.run(["git", "-C", str(tmp_path), *args], check=True, capture_output=True)

    def pack(checkpoint_at: int, steps: list[int], message: str) -> str:
        shutil.rmtree(trial, ignore_errors=True)
        (trial / "checkpoint_000001").mkdir(parents=True)
        with (trial / "checkpoint_000001" / ALGORITHM_STATE).open("wb") as f:
            pickle.dump({"training_iteration": checkpoint_at}, f)
        with open(trial / HISTORY_FILE, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(["training_iteration", "env_runners/num_env_steps_sampled_lifetime"])
            writer.writerows(enumerate(steps, start=1))
        git("add", "-A")
        git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", message)
        return subprocess.run(["git", "-C", str(tmp_path), "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()

    git("init", "-q")
    first = pack(2, [100, 200, 300], "first pack")
    (run / "curriculum.json").write_text("{}")  # a note written later: no pack
    git("add", "-A")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "a note")
    pack(5, [100, 200, 301, 401, 501], "collapsed")
    last = pack(4, [100, 200, 302, 402], "set back and trained again")
    trial_now = read_trial(trial)
    assert packed_commits(run, trial_now) == [last, first]
    trial_now.rows = trial_now.rows[:2]  # exported at iteration 2: before the last pack
    assert packed_commits(run, trial_now) == [first]


@pytest.mark.parametrize("name", ["mysmoke", "quick"])
def test_a_run_of_a_curriculum_file_exports_with_that_file(tmp_path, name):
    """The run trained on a file (issue 40, cases 5 and 6): named 'mysmoke', the export found
    no such curriculum; named 'quick', the card described the shipped quick."""
    mine = tmp_path / "mine" / "mysmoke.toml"
    mine.parent.mkdir()
    mine.write_text((REPO / "curriculum" / "smoke.toml").read_text()
                    .replace('name = "smoke"', f'name = "{name}"'))
    trial = _fake_run(tmp_path / "run", PommerNet())
    params = trial / "params.json"
    params.write_text(params.read_text().replace("name='smoke', path=PosixPath('/elsewhere/"
                                                 "curriculum/smoke.toml')",
                                                 f"name='{name}', path=PosixPath('{mine}')"))
    assert str(mine) in params.read_text()
    target = tmp_path / "ppo"
    assert main(["--out", str(tmp_path / "run"), "--export", str(target)]) == 0
    source = json.loads((target / "source.json").read_text())
    assert source["curriculum"]["name"] == name
    assert [s["name"] for s in source["curriculum"]["stages"]] == ["warmup", "static"]
    assert "18 of 24 games" in (target / "MODEL_CARD.md").read_text()


def _a_file(tmp_path: Path) -> Path:
    (tmp_path / "a_file").write_text("")
    return tmp_path / "a_file"


@pytest.mark.parametrize("target, message", [
    (lambda t: _a_file(t), "--export {t}/a_file: {t}/a_file is a file, not a folder"),
    (lambda t: _a_file(t) / "ppo", "--export {t}/a_file/ppo: {t}/a_file is a file, not a folder"),
    (lambda t: Path("/proc/ppo"), "--export /proc/ppo: cannot write the policy ("),
    (lambda t: Path(""), "--export: no policy folder named (got '.'); give POLICY_DIR"),
])
def test_an_export_target_that_cannot_be_written_is_one_line(tmp_path, capsys, target, message):
    """Issue 40, case 11 and the vague `--export ""`: each was a traceback or a vague line."""
    _fake_run(tmp_path / "run", PommerNet())
    assert main(["--out", str(tmp_path / "run"), "--export", str(target(tmp_path))]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: {message.format(t=tmp_path)}"), err


def test_a_run_is_dagger_s_clone_from_any_working_directory(tmp_path, monkeypatch):
    """Both learned kinds resolve their paths one way, against the policy file: a checkpoint
    policy's relative `checkpoint` works from another working directory, and DAgger's actor
    names the module state it read (its weights' fingerprint), not the run folder."""
    torch.manual_seed(4)
    trial = _fake_run(tmp_path / "run", PommerNet())
    policy = tmp_path / "ppo_run.toml"
    policy.write_text('kind = "rllib_checkpoint"\ncheckpoint = "run"\ngreedy = true\n')
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    for name in (str(policy), str(tmp_path / "run")):
        act, source = greedy_actor(name)
        assert source == (trial / "checkpoint_000002" / MODULE_STATE).resolve()
        obs = Games(1).reset([0]).agent_rows()
        assert act(obs).shape == (NUM_AGENTS,)
    planned = Collection(tmp_path / "dagger", 2, 0, 2, 4, Dagger(str(policy), ("static",),
                                                                 greedy_actor)).plan[0]
    assert planned.policy_sha256 == hashlib.sha256(source.read_bytes()).hexdigest()
