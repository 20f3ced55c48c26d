"""`train --out RUN --export policies/NAME`: a run's learner shipped as `imitation` is, a plain
state_dict and a policy file that the arena plays, never over an existing policy."""

from __future__ import annotations

import pickle
from collections import OrderedDict

import torch

from rllib_pommer.arena.match import MatchSpec, play_match
from rllib_pommer.imitation.network import PommerNet
from rllib_pommer.rl.checkpoint_policy import MODULE_STATE
from rllib_pommer.train import main


def _fake_run(run, pi: PommerNet):
    """A run folder whose newest checkpoint holds `pi` (and a value net) as RLlib saves them."""
    state = OrderedDict((f"pi.{k}", v.numpy()) for k, v in pi.state_dict().items())
    state["vf.head.weight"] = torch.zeros(1, 4).numpy()
    for number in (1, 2):  # an older checkpoint too: the newest one is exported
        path = run / "PPO_trial" / f"checkpoint_00000{number}" / MODULE_STATE
        path.parent.mkdir(parents=True)
        with path.open("wb") as f:
            pickle.dump(state if number == 2 else OrderedDict(), f)


def test_export_writes_a_plain_state_dict_and_a_policy_the_arena_plays(tmp_path, capsys):
    torch.manual_seed(3)
    pi = PommerNet()
    _fake_run(tmp_path / "run", pi)
    target = tmp_path / "policies" / "ppo"
    assert main(["--out", str(tmp_path / "run"), "--export", str(target)]) == 0
    weights = torch.load(target / "pi.pt", weights_only=True)
    assert weights.keys() == pi.state_dict().keys()
    assert all(torch.equal(weights[k], v) for k, v in pi.state_dict().items())
    policy_file = target.with_suffix(".toml")
    assert 'weights = "ppo/pi.pt"' in policy_file.read_text()
    assert "checkpoint_000002" in policy_file.read_text()
    records = list(play_match(MatchSpec(team=str(policy_file), vs="static", games=2), workers=1))
    assert len(records) == 2
    capsys.readouterr()
    assert main(["--out", str(tmp_path / "run"), "--export", str(target)]) == 2
    assert f"{target / 'pi.pt'} exists" in capsys.readouterr().err
