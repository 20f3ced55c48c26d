"""PPO and run settings written once (curriculum/settings.py): a curriculum overrides only the
options, the
PPOConfig carries every value, the committed campaign resumes with the values it started with,
and `train`'s options are the fields of RunSettings, checked before Ray starts."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.settings import PPOSettings, RunSettings
from rllib_pommer.rl.config import build_config
from rllib_pommer.rl.teacher import TEACHER_WEIGHT_KEY

from ..conftest import REPO_ROOT
from ..test_layering import _loaded

STAGE = '[[stage]]\nname = "a"\nopponent = "static"\nepisodes = 5\n'

# Each PPOSettings field and where RLlib's PPOConfig keeps it.
CONFIG_KEYS = {"lr": "lr", "gamma": "gamma", "lambda_": "lambda", "num_epochs": "num_epochs",
               "train_batch_size": "_train_batch_size_per_learner",
               "num_envs_per_env_runner": "num_envs_per_env_runner",
               "vf_loss_coeff": "vf_loss_coeff", "entropy_coeff": "entropy_coeff",
               "clip_param": "clip_param", "minibatch_size": "minibatch_size",
               "use_kl_loss": "use_kl_loss", "grad_clip": "grad_clip"}


def _config_values(config: dict) -> dict:
    return {field: config[key] for field, key in CONFIG_KEYS.items()}


def test_every_setting_but_checkpointing_reaches_the_ppo_config(tmp_path):
    assert set(CONFIG_KEYS) | {"checkpoint_every", "dual_clip", "teacher", "teacher_weight"} == {
        f.name for f in dataclasses.fields(PPOSettings)}
    (tmp_path / "c.toml").write_text(
        "[ppo]\nlr = 3e-4\nlambda = 0.9\nnum_epochs = 2\ndual_clip = 3\n" + STAGE)
    curriculum = load_curriculum(tmp_path / "c.toml")
    assert curriculum.ppo == PPOSettings(lr=3e-4, lambda_=0.9, num_epochs=2, dual_clip=3.0)
    expected = dataclasses.asdict(curriculum.ppo)
    del expected["checkpoint_every"]  # Tune's, not PPO's: launch/training.py
    config = build_config(curriculum, restore_from=Path("checkpoint")).to_dict()
    del expected["teacher"]  # the connector's (teacher.py), tested in test_teacher.py
    assert config["learner_config_dict"] == {  # learner.py; no teacher, no teacher loss
        "dual_clip": expected.pop("dual_clip"), TEACHER_WEIGHT_KEY: 0.0}
    del expected["teacher_weight"]
    assert _config_values(config) == expected


@pytest.mark.parametrize("table, error", [
    ("clip_param = 0.2", "unknown key 'clip_param'"),  # the paper's, not an option
    ("lambda_ = 0.9", "unknown key 'lambda_'"),  # the file says lambda, as RLlib's docs do
    ("gamma = 1.5", "gamma must be in (0, 1], got 1.5"),
    ("num_epochs = 0", "num_epochs must be a positive integer, got 0"),
    ("lr = true", "lr must be a number, got True"),
    ("dual_clip = 1", "dual_clip must be in (1, inf], got 1"),
])
def test_a_ppo_table_sets_options_only_and_in_range(tmp_path, table, error):
    (tmp_path / "c.toml").write_text(f"[ppo]\n{table}\n" + STAGE)
    with pytest.raises(ValueError, match="c.toml \\[ppo\\]") as raised:
        load_curriculum(tmp_path / "c.toml")
    assert error in str(raised.value)


def test_the_committed_campaign_resumes_with_the_ppo_settings_it_started_with():
    """The trial config Tune wrote as data (params.json) when campaign/paper started, against
    the config this code builds for `--resume`."""
    trials = sorted((REPO_ROOT / "campaign" / "paper").glob("PPO_*/params.json"))
    if not trials:
        pytest.skip("no committed campaign in this checkout")
    started = json.loads(trials[0].read_text())
    config = build_config(load_curriculum("paper"), restore_from=Path("checkpoint")).to_dict()
    assert _config_values(started) == _config_values(config)


@pytest.mark.parametrize("option, value, error", [
    ("--num-cpus", "0", "--num-cpus must be 1 or more, got 0"),
    ("--torch-threads", "0", "--torch-threads must be 1 or more, got 0"),
    ("--num-env-runners", "-2", "--num-env-runners must be 0 or more, got -2"),
    ("--seed", "x", "argument --seed: invalid int value: 'x'"),
])
def test_train_options_are_run_settings_checked_before_ray(tmp_path, capsys, option, value, error):
    from rllib_pommer.train import main

    with pytest.raises(SystemExit) as exited:
        main(["--out", str(tmp_path / "run"), option, value])
    assert exited.value.code == 2 and error in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_train_help_lists_every_run_setting_with_its_default(capsys):
    from rllib_pommer.train import main

    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    for field in dataclasses.fields(RunSettings):
        assert "--" + field.name.replace("_", "-") in text
    text = " ".join(text.split())  # argparse wraps the help texts
    assert "(default: quick; with --resume, the run's own" in text and "(default 2)" in text


def test_our_ray_gets_the_run_settings_cpus(monkeypatch):
    import ray
    import torch

    from rllib_pommer.launch.training import init_ray

    calls = []
    monkeypatch.setattr(ray, "init", lambda **kwargs: calls.append(kwargs))
    threads = torch.get_num_threads()
    try:
        init_ray(None)
        init_ray(None, num_cpus=1, torch_threads=2)
        assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(threads)
    assert [call["num_cpus"] for call in calls] == [RunSettings().num_cpus, 1] == [2, 1]


def test_settings_and_the_train_parser_load_neither_ray_nor_torch():
    parse = ("import argparse; rllib_pommer.util.cli_options.add_options("
             "argparse.ArgumentParser(), rllib_pommer.curriculum.settings.RunSettings, {})")
    assert _loaded(["rllib_pommer.curriculum.settings", "rllib_pommer.util.cli_options",
                    "rllib_pommer.train"], ("ray", "torch"), parse) == ""
