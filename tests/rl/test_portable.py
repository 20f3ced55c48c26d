"""A checkpoint is self-contained: the committed campaign's checkpoint, made before this was so,
restores (the module alone by RLlib's `from_checkpoint`, and the whole algorithm as a resume
builds it: from the curriculum's data, loading the checkpoint's state) where the imitation
weights file it names no longer exists, and plays episodes. (A packed run moved, resumed and
played without its weights file: test_resume.py.)"""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from rllib_pommer.curriculum.curriculum import load_curriculum

from .conftest import CURRICULUM

RESTORE = """
import json, sys
from pathlib import Path
import ray, torch
from ray.rllib.core.rl_module.rl_module import RLModule
from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.rl.config import build_config
from rllib_pommer.runs.checkpoints import load_checkpoint_net
from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS, NUM_EPISODES_LIFETIME
from rllib_pommer.curriculum.names import LEARNER

checkpoint, weights, curriculum = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
expected = load_checkpoint_net(checkpoint).state_dict()
same = lambda pi: all(torch.equal(pi.state_dict()[k], v) for k, v in expected.items())
module = RLModule.from_checkpoint(checkpoint / "learner_group/learner/rl_module/learner")
ray.init(address="local", num_cpus=2, include_dashboard=False)
try:
    # no Tune: the stage must follow anyway
    algo = build_config(load_curriculum(curriculum), restore_from=checkpoint).build_algo()
    learner = algo.learner_group._learner.module[LEARNER]
    print(json.dumps({
        "weights_visible": weights.exists(), "module_pi": same(module.pi),
        "module_source": module.pi_source, "algo_pi": same(learner.pi),
        "algo_source": learner.pi_source, "pi_frozen": learner.pi_frozen,
        "mapping_stage": algo.env_runner.config.policy_mapping_fn.stage,
        "episodes": int(algo.metrics.peek((ENV_RUNNER_RESULTS, NUM_EPISODES_LIFETIME))),
        "played": sorted({e.module_id for episode in algo.env_runner.sample(
            num_timesteps=300, explore=True) for e in episode.agent_episodes.values()})}))
    algo.stop()
finally:
    ray.shutdown()
"""


def _hiding(path: Path) -> list[str]:
    """A command prefix under which `path` does not exist: where it does, its folder is covered
    by an empty tmpfs in a private mount namespace (root only; nothing outside sees it)."""
    if not path.exists():
        return []
    cover = f"mount -t tmpfs none {shlex.quote(str(path.parent))}"
    probe = subprocess.run(["unshare", "-m", "sh", "-c", cover], capture_output=True, text=True)
    if probe.returncode != 0:
        pytest.skip(f"cannot hide {path} here (no private mount namespace: {probe.stderr[:200]})")
    return ["unshare", "-m", "sh", "-c", f'{cover} && exec "$@"', "sh"]


def test_the_committed_campaign_checkpoint_restores_without_its_weights_file(
        tmp_path, committed_campaign):
    run = committed_campaign
    (trial,) = [p for p in run.iterdir() if (p / "params.json").is_file()]
    checkpoint = max(trial.glob("checkpoint_*"))
    named = re.search(r"'pi_weights': '([^']+)'", (trial / "params.json").read_text())
    weights = Path(named.group(1))  # the absolute path the run was built with
    done = subprocess.run([*_hiding(weights), sys.executable, "-c", RESTORE, str(checkpoint),
                           str(weights), CURRICULUM], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    # the campaign moves on between commits: the stage in force is the one its curriculum gives
    # for the checkpoint's lifetime episode count
    index = load_curriculum(CURRICULUM).stage_at(seen.pop("episodes"))
    stage = load_curriculum(CURRICULUM).stages[index]
    assert seen == {"weights_visible": False, "module_pi": True, "module_source": "checkpoint",
                    "algo_pi": True, "algo_source": "checkpoint",
                    "pi_frozen": stage.freeze_pi, "mapping_stage": index,
                    # and it plays its scripted modules
                    "played": sorted({"learner", stage.teammate, stage.opponent})}


def test_the_module_takes_pi_from_the_weights_or_a_checkpoint_and_never_trains_without(
        tmp_path, pi_weights):
    from rllib_pommer.envs.team import ACTION_SPACE, OBSERVATION_SPACE
    from rllib_pommer.rl.rl_module import PommerPPOModule

    def module(weights):
        return PommerPPOModule(observation_space=OBSERVATION_SPACE, action_space=ACTION_SPACE,
                               model_config={"pi_weights": str(weights)})

    started = module(pi_weights)
    assert started.pi_source == f"imitation weights {pi_weights}"
    started.require_pi()
    moved = module(tmp_path / "gone" / "pi.pt")  # as restoring on another machine builds it
    assert moved.pi_source is None
    with pytest.raises(ValueError, match=r"pi has no weights: .*gone/pi.pt were not found"):
        moved.require_pi()
    moved.set_state(started.get_state())  # what a restore does next
    assert moved.pi_source == "checkpoint"
    moved.require_pi()


def test_a_curriculum_with_vf_weights_starts_vf_from_them_and_checks_the_file(tmp_path, pi_weights):
    """A run that continues another's (curriculum `vf_weights`): the module's vf is the file's,
    and a file that is missing or not a value network is named before Ray starts."""
    import torch

    from rllib_pommer.curriculum.names import LEARNER
    from rllib_pommer.envs.team import ACTION_SPACE, OBSERVATION_SPACE
    from rllib_pommer.imitation.network import PommerNet
    from rllib_pommer.rl.config import build_config
    from rllib_pommer.rl.rl_module import PommerPPOModule

    torch.manual_seed(1)
    vf = PommerNet(1)
    torch.save(vf.state_dict(), tmp_path / "vf.pt")
    stage = '[[stage]]\nname = "a"\nopponent = "static"\nepisodes = 5\n'
    (tmp_path / "c.toml").write_text(f'pi_weights = "{pi_weights}"\nvf_weights = "vf.pt"\n'
                                     + stage)
    config = build_config(load_curriculum(tmp_path / "c.toml"))
    model_config = config.rl_module_spec.rl_module_specs[LEARNER].model_config
    assert model_config["vf_weights"] == str(tmp_path / "vf.pt")
    module = PommerPPOModule(observation_space=OBSERVATION_SPACE, action_space=ACTION_SPACE,
                             model_config=model_config)
    for key, value in vf.state_dict().items():
        assert torch.equal(module.vf.state_dict()[key], value), key

    torch.save(PommerNet().state_dict(), tmp_path / "vf.pt")  # a policy network, 6 outputs
    with pytest.raises(ValueError, match=r"vf.pt: weights do not fit PommerNet"):
        build_config(load_curriculum(tmp_path / "c.toml"))
    (tmp_path / "vf.pt").unlink()
    with pytest.raises(ValueError, match=r"vf_weights not found: .*vf.pt"):
        build_config(load_curriculum(tmp_path / "c.toml"))
