"""Errors name the file, the key and the valid choices; missing weights and addresses are named."""

from __future__ import annotations

import collections
import json
import os
import pickle
import re
import socket
from pathlib import Path

import numpy as np
import pytest

from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.launch.packing import pack_run, stop_run
from rllib_pommer.launch.training import check_run_dir, init_ray
from rllib_pommer.rl.config import build_config
from rllib_pommer.runs.checkpoints import MODULE_STATE, load_checkpoint_net

STAGE = '[[stage]]\nname = "a"\nopponent = "static"\nepisodes = 5\n'


def _write(tmp_path, text):
    path = tmp_path / "c.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("text, words", [
    (STAGE.replace('"static"', '"simpel"'), ["opponent", "simpel", "simple_nobomb"]),
    (STAGE + 'teamate = "simple"\n', ["teamate", "teammate"]),
    (STAGE.replace("episodes = 5", "episodes = -1"), ["episodes"]),
    (STAGE + 'reward = "dense"\n', ["reward", "shaped", "raw"]),
    ("[ppo]\nlearning_rate = 1\n" + STAGE, ["[ppo]", "learning_rate", "lr"]),
    (STAGE.replace('"static"', '"simpel_action"'), ["unknown policy 'simpel_action'"]),
    (STAGE + "freeze_pi = \"no\"\n", ["freeze_pi must be true or false, got 'no'"]),
    (STAGE.replace('"static"', "5"), ["opponent must be a policy name or a list", "got 5"]),
    ("[ppo]\ntrain_batch_size = \"big\"\n" + STAGE,
     ["train_batch_size must be a positive integer, got 'big'"]),
    ("[ppo]\ngamma = 1.5\n" + STAGE, ["gamma must be in (0, 1]"]),
    ("max_steps = -10\n" + STAGE, ["max_steps must be a positive integer, got -10"]),
    ('max_steps = "abc"\n' + STAGE, ["max_steps must be a positive integer, got 'abc'"]),
    (STAGE.replace("episodes = 5", "episodes = 2.5"), ["episodes must be a positive integer"]),
    (STAGE + "action_filter = true\n", ["action_filter must be a number, got True"]),
])
def test_curriculum_errors_name_file_key_and_choices(tmp_path, text, words):
    path = _write(tmp_path, text)
    with pytest.raises(ValueError) as info:
        load_curriculum(path)
    assert str(path) in str(info.value)
    for word in words:
        assert word in str(info.value)


def test_unknown_curriculum_name_lists_names():
    with pytest.raises(ValueError, match="paper"):
        load_curriculum("no_such_curriculum")


def test_missing_imitation_weights(tmp_path):
    curriculum = load_curriculum(_write(tmp_path, STAGE))
    with pytest.raises(ValueError, match="imitation weights not found"):
        build_config(curriculum, pi_weights=tmp_path / "absent.pt")


def test_unreachable_ray_address():
    with pytest.raises(ValueError, match="unreachable"):
        init_ray("127.0.0.1:1")


def test_a_cluster_that_wants_a_token_says_how_to_give_it(monkeypatch):
    """What Ray 2.60 raises when `ray start` turned token authentication on and we have none."""
    import ray

    def refuse(**kwargs):
        try:
            raise RuntimeError("Failed to connect to GCS. ... ray.exceptions.AuthenticationError: "
                               "RPC error: InvalidAuthToken: Authentication token is missing")
        except RuntimeError as cause:
            raise ConnectionError("Failed to connect to Ray cluster at 127.0.0.1:6379") from cause

    with socket.create_server(("127.0.0.1", 0)) as head:  # a port that answers
        monkeypatch.setattr(ray, "init", refuse)
        with pytest.raises(ValueError, match="RAY_AUTH_MODE=token") as info:
            init_ray(f"127.0.0.1:{head.getsockname()[1]}")
    assert "wants a token" in str(info.value)


class _RunsACommand:
    """Unpickling this calls os.system: what a crafted checkpoint would do."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return os.system, (f"touch {self.marker}",)


@pytest.mark.parametrize("content, words", [
    (lambda tmp: pickle.dumps({"pi.x": _RunsACommand(tmp / "pwned")}), ["refused global",
                                                                        "system"]),
    (lambda tmp: pickle.dumps(collections.OrderedDict(a=np.zeros(3)))[:20], ["module state"]),
    (lambda tmp: b"", ["module state"]),
    (lambda tmp: pickle.dumps([np.zeros(3)]), ["list, not a dict"]),
    (lambda tmp: pickle.dumps({"pi.convs.0.weight": np.zeros(3)}), ["do not fit PommerNet"]),
])
def test_a_checkpoint_never_runs_code_and_bad_states_are_named(tmp_path, content, words):
    state_file = tmp_path / "ckpt" / MODULE_STATE
    state_file.parent.mkdir(parents=True)
    state_file.write_bytes(content(tmp_path))
    with pytest.raises(ValueError) as info:
        load_checkpoint_net(tmp_path / "ckpt")
    assert str(state_file) in str(info.value)
    for word in words:
        assert word in str(info.value)
    assert not (tmp_path / "pwned").exists()


def test_run_folders_are_checked_by_relative_path_too(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    check_run_dir(Path("runs") / "new", resume=False)  # a new run: fine
    with pytest.raises(ValueError, match="no run to resume"):
        check_run_dir(Path("runs") / "new", resume=True)
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match="is a file"):
        check_run_dir(Path("file"), resume=False)
    with pytest.raises(ValueError, match="--pack: no run in"):
        pack_run(Path("runs") / "new")
    with pytest.raises(ValueError, match="--stop: no run is training in .*runs/new"):
        stop_run(Path("runs") / "new")
    (tmp_path / "runs" / "new").mkdir(parents=True)  # a run whose driver has exited
    (tmp_path / "runs" / "new" / "ray_session.json").write_text(json.dumps(
        {"session_dir": "/tmp/ray/session_x", "driver_pid": 1, "driver_start": "0"}))
    with pytest.raises(ValueError, match="no live driver noted in its ray_session.json"):
        stop_run(Path("runs") / "new")


def test_a_run_still_training_is_not_packed(tmp_path):
    """Its driver (here: this process) is alive: pack touches nothing."""
    from rllib_pommer.launch import ray_session

    run = tmp_path / "run"
    (run / "PPO_trial" / "checkpoint_000001").mkdir(parents=True)
    note = {"session_dir": str(tmp_path / "session_x"), "driver_pid": os.getpid(),
            "driver_start": ray_session._start_time(os.getpid())}
    (run / "ray_session.json").write_text(json.dumps(note))
    before = sorted(p.relative_to(run) for p in run.rglob("*"))
    with pytest.raises(ValueError, match=f"--pack: .* a run \\(pid {os.getpid()}\\) is still"):
        pack_run(run)
    assert sorted(p.relative_to(run) for p in run.rglob("*")) == before


def _no_ray(monkeypatch):
    """Ray never starts: a start is noted in the returned list and fails (train exits 1). The
    job's shutdown after a failed start is kept off the Ray the other RL tests share."""
    import ray

    started = []

    def note(**kwargs):
        started.append(kwargs)
        raise RuntimeError("not in this test")

    monkeypatch.setattr(ray, "init", note)
    monkeypatch.setattr(ray, "shutdown", lambda: None)
    return started


@pytest.mark.parametrize("args, words", [
    (["--num-env-runners", "-1"], ["--num-env-runners must be 0 or more, got -1"]),
    (["--curriculum", "no_such_curriculum"], ["curriculum 'no_such_curriculum' not found"]),
    (["--pi-weights", "absent.pt"], ["imitation weights not found: absent.pt"]),
    (["--resume"], ["--resume: no run to resume"]),
    (["--seed", "-1"], ["--seed must be 0 or more, got -1"]),  # issue 40: say which option
])
def test_train_checks_its_arguments_before_ray_starts(tmp_path, monkeypatch, capsys, args, words):
    from rllib_pommer.train import main

    started = _no_ray(monkeypatch)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exited:
        main(["--curriculum", "smoke", "--out", str(tmp_path / "run"), *args])
    assert exited.value.code == 2 and started == []
    for word in words:
        assert word in capsys.readouterr().err


def test_a_resume_without_a_checkpoint_needs_the_weights(tmp_path, monkeypatch, capsys):
    """A run with no checkpoint starts over: pi must come from the file."""
    from rllib_pommer.train import main

    started = _no_ray(monkeypatch)
    run = tmp_path / "run"
    (run / "PPO_pommerman_team_0").mkdir(parents=True)
    (run / "PPO_pommerman_team_0" / "params.json").write_text("{}")
    monkeypatch.setattr("rllib_pommer.launch.training.pack_run",  # the newest checkpoint, if any
                        lambda out: next(iter(sorted(out.glob("*/checkpoint_*"))), None))
    with pytest.raises(SystemExit):
        main(["--curriculum", "smoke", "--out", str(run), "--resume",
              "--pi-weights", str(tmp_path / "absent.pt")])
    assert started == [] and "imitation weights not found" in capsys.readouterr().err
    (run / "PPO_pommerman_team_0" / "checkpoint_000000").mkdir()  # pi comes from it
    assert main(["--curriculum", "smoke", "--out", str(run), "--resume",
                 "--pi-weights", str(tmp_path / "absent.pt")]) == 1
    assert len(started) == 1  # got as far as starting Ray


def test_a_ray_that_does_not_start_is_one_line_with_what_to_check(tmp_path, monkeypatch, capsys,
                                                                 pi_weights):
    import ray

    from rllib_pommer.train import main

    def time_out(**kwargs):
        raise TimeoutError("Timed out after 60 seconds waiting for the GCS to start.\n"
                           "  File ... (a long traceback)")

    monkeypatch.setattr(ray, "init", time_out)
    monkeypatch.setattr(ray, "shutdown", lambda: None)  # as in _no_ray
    assert main(["--curriculum", "smoke", "--out", str(tmp_path / "run"),
                 "--pi-weights", str(pi_weights)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: a local Ray instance did not start "
                                                   "(TimeoutError: Timed out after 60 seconds")
    assert "/tmp/ray/session_latest/logs" in err and "Traceback" not in err


def test_vf_weights_of_the_wrong_shape_are_refused_before_ray(tmp_path, monkeypatch, capsys,
                                                             pi_weights):
    """Issue 40: caught only after Ray started, leaving ray_session.json behind; now checked
    before, as pi_weights is."""
    import torch

    from rllib_pommer.curriculum.curriculum import curriculum_dir
    from rllib_pommer.imitation.network import PommerNet
    from rllib_pommer.train import main

    started = _no_ray(monkeypatch)
    torch.save(PommerNet().state_dict(), tmp_path / "vf.pt")  # a policy net: 6 outputs, not 1
    curriculum = tmp_path / "c.toml"
    curriculum.write_text('vf_weights = "vf.pt"\n' + (curriculum_dir() / "smoke.toml").read_text())
    out = tmp_path / "run"
    with pytest.raises(SystemExit) as exited:
        main(["--curriculum", str(curriculum), "--out", str(out), "--pi-weights", str(pi_weights)])
    assert exited.value.code == 2 and started == []
    assert f"{tmp_path / 'vf.pt'}: weights do not fit PommerNet" in capsys.readouterr().err
    assert not out.exists()


def _on_a_cluster(monkeypatch, free_cpus: float):
    """A cluster at HEAD with `free_cpus` free CPUs, joined without Ray starting; returns the
    list of shutdowns and the curricula training was handed."""
    import ray

    from rllib_pommer.launch import training

    shutdowns, handed = [], []
    monkeypatch.setattr(training, "init_ray", lambda *args, **kwargs: None)
    monkeypatch.setattr(ray, "available_resources", lambda: {"CPU": free_cpus})
    monkeypatch.setattr(ray, "shutdown", lambda: shutdowns.append(1))
    monkeypatch.setattr(training, "train", lambda curriculum, out, settings, start=None:
                        handed.append(settings) or type("Result", (), {
                            "checkpoint": None, "path": str(out), "metrics": {
                                "curriculum": {"episodes": curriculum.total_episodes}}})())
    return shutdowns, handed


def test_a_cluster_too_small_for_the_runners_is_said_up_front(tmp_path, monkeypatch, capsys,
                                                              pi_weights):
    """Issue 40, case 16: 2 free CPUs, and the run asks for 3 (1 + 1 per runner): Tune waited
    for ever. Now the command says what is missing and leaves the cluster."""
    from rllib_pommer.train import main

    shutdowns, handed = _on_a_cluster(monkeypatch, 2.0)
    args = ["--curriculum", "smoke", "--address", "10.0.0.1:6379", "--pi-weights",
            str(pi_weights)]
    with pytest.raises(SystemExit) as exited:
        main([*args, "--out", str(tmp_path / "a"), "--num-env-runners", "2"])
    assert exited.value.code == 2 and handed == [] and shutdowns
    err = capsys.readouterr().err
    assert ("error: the Ray cluster at '10.0.0.1:6379' has 2 free CPUs; the run asks for 3 (1 "
            "for the learner's process, 2 for --num-env-runners 2): pass --num-env-runners 1 "
            "or fewer, or free or add CPUs") in err
    assert main([*args, "--out", str(tmp_path / "b"), "--num-env-runners", "1"]) == 0
    assert [s.num_env_runners for s in handed] == [1]


def test_the_cluster_check_reads_what_ray_has_free(ray_session):
    """The same check against a real Ray of 2 CPUs (the tests' own), joined as a cluster."""
    from rllib_pommer.curriculum.settings import RunSettings
    from rllib_pommer.launch.training import check_cluster_fits

    check_cluster_fits(RunSettings(address="auto", num_env_runners=1))
    with pytest.raises(ValueError, match="has 2 free CPUs; the run asks for 3"):
        check_cluster_fits(RunSettings(address="auto", num_env_runners=2))


LEAGUE = "[league]\nslots = 2\ngate_games = 4\n"


@pytest.mark.parametrize("text, message", [
    (STAGE.replace('"static"', '"elsewhere/pol.toml"'),
     "stage 1 key 'opponent': 'elsewhere/pol.toml' is a path; a curriculum names its policies "
     "by their names in "),
    (STAGE.replace('"static"', '"pol.toml"'), "'pol.toml' is a path"),
    (STAGE + 'teammate = "runs/quick"\n', "key 'teammate' (a policy, or 'learner': the trained "
                                          "one): 'runs/quick' is a path"),
    ('game = "radio"\n' + STAGE + "self_play = true\n",
     "stage 1: self_play (snapshots of the learner, Team nets) plays the Team game only, not "
     "game 'radio'"),
    (LEAGUE + STAGE, "no stage has self_play = true, so the [league] table's snapshots would "
                     "never play"),
    (LEAGUE.replace("slots = 2", "slots = 17") + STAGE + "self_play = true\n",
     "[league]: slots must be at most 16, got 17"),
])
def test_curriculum_cases_of_issue_50_are_one_line_naming_the_file(tmp_path, text, message):
    """Cases 20, 22, 26 and 28: refused on load, before Ray starts, naming the curriculum."""
    path = _write(tmp_path, text)
    with pytest.raises(ValueError) as info:
        load_curriculum(path)
    assert str(info.value).startswith(f"curriculum file {path}")
    assert message in str(info.value) and "\n" not in str(info.value)


def test_an_opponents_policy_file_is_checked_as_the_arena_checks_it(tmp_path, monkeypatch):
    """A learned opponent whose file the arena refuses (temperature nan) is refused when the
    curriculum loads, naming both files, not after Ray starts (issue 50, case 12)."""
    policies = tmp_path / "policies"
    policies.mkdir()
    (policies / "hot.toml").write_text('kind = "learned"\nweights = "net.pt"\n'
                                       'temperature = nan\n')
    monkeypatch.setenv("RLLIB_POMMER_POLICIES", str(policies))
    path = _write(tmp_path, STAGE.replace('"static"', '"hot"'))
    with pytest.raises(ValueError, match=re.escape(
            f"curriculum file {path} stage 1 key 'opponent': policy file {policies / 'hot.toml'}"
            f": temperature must be a positive number, got nan")):
        load_curriculum(path)
