"""Errors name the file, the key and the valid choices; missing weights and addresses are named."""

from __future__ import annotations

import collections
import os
import pickle
import socket
from pathlib import Path

import numpy as np
import pytest

from rllib_pommer.rl.checkpoint_policy import MODULE_STATE, load_checkpoint_net
from rllib_pommer.rl.config import build_config
from rllib_pommer.rl.curriculum import load_curriculum
from rllib_pommer.rl.training import check_run_dir, init_ray, pack_run

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
    (STAGE.replace('"static"', '"simple_action"'), ["simple_action", "filter"]),
    (STAGE + "freeze_pi = \"no\"\n", ["freeze_pi must be true or false, got 'no'"]),
    (STAGE.replace('"static"', "5"), ["opponent must be a string, got 5"]),
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
