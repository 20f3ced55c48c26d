"""The PPOConfig of a curriculum: env, modules, mapping, connectors, callback and PPO settings.

Paper settings (fixed): entropy coefficient 0, clip 0.01, minibatch 128, no dropout. The others
are our choices, each a default of `settings.PPOSettings` that a curriculum's [ppo] table may
override:

- lr 1e-4: small, so that pi stays near the imitation policy it starts from;
- gamma 0.999: every outcome is paid at a game's end, up to `MAX_STEPS` steps away; with 0.99 a
  tie's -1 some 400 steps away is worth -0.02 now, so waiting out the clock beats any risky
  attack;
- GAE lambda 0.95; 4 epochs over batches of 4,000 env steps (all four agents step, and the
  learner's rows are the ones trained);
- value loss coefficient 1 with RLlib's value clip 10 (returns lie in [-1, 1]); no KL penalty
  (the clip does the work); no dual clip unless a curriculum sets `dual_clip` (learner.py);
  gradient norm clip 10;
- 8 envs per env runner: inference is batched over them, and more envs amortise RLlib's per-step
  connector and inference calls; the campaigns keep 8 so that they stay comparable, and a run
  may set `num_envs_per_env_runner` in its [ppo] table.

Layout (`train --num-env-runners N --torch-threads T`, not PPO's arithmetic): by default the
algorithm's process samples and learns on one thread, so two runs share a 2-core machine, one per
core, the most work per hour when there are several runs to do; a run alone on 2 cores goes
faster with 2 remote env runners and 2 learner threads (`bench scale` compares them). A
resumed run is built afresh from its data (launch/training.py), so it takes the layout its
command asks for.

Learners (`train --num-learners N`, `--num-gpus-per-learner`, `--num-cpus-per-learner`): 0 keeps
the one learner in the algorithm's process; N learner actors share each update data-parallel
(rl/learner.py averages their gradients). They split the curriculum's PPO batch rather than
multiply it: each learner takes 1/N of the iteration's env steps and 1/N of each minibatch's
rows (rounded up), so an iteration samples as many games and takes as many optimizer steps of
as many rows as with one learner, and the paper's minibatch of 128 stays 128 rows a step
(RLlib's `train_batch_size_per_learner` and `minibatch_size` are per learner).

Speed settings, none of which changes what PPO computes:

- the module (rl_module.py) runs pi and vf channels-last and vf under bfloat16 autocast, and the
  learner (learner.py) uses fused Adam; pi stays float32 (rl_module.py says why);
- `episodes_to_numpy=False`: RLlib's env runner would convert every finished episode of a sample
  call to numpy again after each env step (quadratic in the episodes per call); the learner
  connector batches lists as well, so episodes stay lists;
- the learner's connector batches only the agents of trained modules (`learner.py`,
  `trained_agents.py`) instead of building every agent's rows and dropping the fixed seats'; the
  learner batch is the same.

What each choice was measured to gain: docs/measurements.md.
"""

from __future__ import annotations

import math
from functools import partial
from pathlib import Path

from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
from ray.rllib.core.rl_module.rl_module import RLModuleSpec

from ..curriculum.curriculum import Curriculum, curriculum_ref
from ..curriculum.mapping import SeatMapping
from ..curriculum.names import ENV_NAME, EXPLOITER, LEARNER
from ..imitation.learned import load_policy_net
from ..runs.checkpoints import NET_OUTPUTS
from . import env as _env  # noqa: F401  (registers ENV_NAME with Tune)
from .connectors import learner_filters
from .fixed_modules import fixed_module_spec
from .league import LeagueCallback, snapshot_specs
from .learner import DUAL_CLIP_KEY, PommerPPOLearner
from .outcomes import OutcomeMetrics
from .rl_module import PommerPPOModule
from .stages import StageCallback
from .teacher import TEACHER_WEIGHT_KEY

# what each of the learner's weights files is, and where it comes from, for check_weights' error
WEIGHTS_HINTS = {
    "pi": ("imitation weights", "train them with `python -m rllib_pommer.imitate`, set "
                                "pi_weights in the curriculum file, or pass --pi-weights"),
    "vf": ("vf_weights", "the curriculum file names it"),
}


def check_weights(path: Path, part: str = "pi", radio: bool = False) -> Path:
    """The weights file of the learner's `part` ("pi" or "vf", checkpoint_policy.NET_OUTPUTS),
    resolved, once it has loaded into the network the learner builds (a PommerNet, with `radio`
    a RadioNet): a missing, cut short or foreign file is named here, before Ray starts, not deep
    inside a Ray actor."""
    if not Path(path).exists():
        what, source = WEIGHTS_HINTS[part]
        raise ValueError(f"{what} not found: {path} ({source})")
    load_policy_net(path, NET_OUTPUTS[part], radio=radio)
    return Path(path).resolve()


def build_config(curriculum: Curriculum, *, pi_weights: str | Path | None = None,
                 num_env_runners: int = 0, cpus_per_env_runner: float = 1.0,
                 seed: int = 0, env: str = ENV_NAME,
                 restore_from: Path | None = None, num_learners: int = 0,
                 num_gpus_per_learner: float = 0.0,
                 num_cpus_per_learner: float = 1.0) -> PPOConfig:
    """PPO for `curriculum`; `pi_weights` overrides the file's; `env` may name another env with
    the same spaces (the bench's zero-cost twin). `restore_from`: a checkpoint the algorithm
    loads when it is built (rl/stages.py), which holds pi, so the imitation weights may be
    absent (rl_module.py). `num_env_runners` remote runners of `cpus_per_env_runner` Ray CPUs
    each sample while the learner waits (its torch threads: names.LEARNER_THREADS_ENV);
    `num_learners` learner actors of `num_gpus_per_learner` GPUs and `num_cpus_per_learner`
    CPUs each split every update (module docstring), 0 keeps the learner in the algorithm's
    process (on a GPU too where `num_gpus_per_learner` asks for one). Every
    object of ours the config holds is built from plain data by a class on the map's list of
    stable import paths (docs/architecture.md), which is all a run's saved config names."""
    restoring = restore_from is not None
    radio = curriculum.game == "radio"
    weights = Path(pi_weights) if pi_weights else curriculum.pi_weights
    weights = weights.resolve() if restoring else check_weights(weights, radio=radio)
    first = curriculum.stages[0]
    ppo = curriculum.ppo
    model_config = {"pi_weights": str(weights)}
    vf_weights = curriculum.vf_weights
    if vf_weights:  # only then: a run under way resumes with the keys it started with
        model_config["vf_weights"] = str(vf_weights if restoring else check_weights(
            vf_weights, part="vf", radio=radio))
    env_config = {"max_steps": curriculum.max_steps, "reward": first.reward,
                  "action_filter": first.action_filter, "jitter": first.jitter}
    if radio:  # only then, as vf_weights (the learner module reads it from the spaces)
        env_config["game"] = "radio"
    if curriculum.memory:  # only then: the planes are 22 (imitation/recall.py)
        env_config["memory"] = True
    modules = {LEARNER: RLModuleSpec(module_class=PommerPPOModule, model_config=model_config)}
    trained = [LEARNER]
    if curriculum.league and curriculum.league.exploiter:  # the same start (league.py)
        modules[EXPLOITER] = RLModuleSpec(module_class=PommerPPOModule, model_config=model_config)
        trained.append(EXPLOITER)
    modules |= {name: fixed_module_spec(name) for name in curriculum.policies()}
    if curriculum.league:  # built empty; the callback's gate fills them (league.py)
        modules |= snapshot_specs(curriculum.league, curriculum.league_members())
    shards = max(num_learners, 1)  # the learners split the batch (module docstring)
    return (
        PPOConfig()
        .environment(env, env_config=env_config)
        .env_runners(
            num_env_runners=num_env_runners,
            num_cpus_per_env_runner=cpus_per_env_runner,
            num_envs_per_env_runner=ppo.num_envs_per_env_runner,
            module_to_env_connector=partial(learner_filters, teacher=ppo.teacher),
            rollout_fragment_length="auto",
            episodes_to_numpy=False)
        .multi_agent(
            policies=set(modules),
            policy_mapping_fn=SeatMapping(0, first.teammate, first.opponent),
            policies_to_train=trained)
        .rl_module(rl_module_spec=MultiRLModuleSpec(rl_module_specs=modules))
        .training(
            entropy_coeff=ppo.entropy_coeff, clip_param=ppo.clip_param,
            minibatch_size=math.ceil(ppo.minibatch_size / shards), lr=ppo.lr, gamma=ppo.gamma,
            lambda_=ppo.lambda_, num_epochs=ppo.num_epochs,
            train_batch_size_per_learner=math.ceil(ppo.train_batch_size / shards),
            vf_loss_coeff=ppo.vf_loss_coeff, use_kl_loss=ppo.use_kl_loss,
            grad_clip=ppo.grad_clip)
        .learners(learner_class=PommerPPOLearner, num_learners=num_learners,
                  num_gpus_per_learner=num_gpus_per_learner,
                  num_cpus_per_learner=num_cpus_per_learner,
                  learner_config_dict={DUAL_CLIP_KEY: ppo.dual_clip,  # inf: PPO's own loss
                                       TEACHER_WEIGHT_KEY: ppo.teacher_weight if ppo.teacher
                                       else 0.0})
        .callbacks([partial(LeagueCallback, curriculum_ref(curriculum)),  # the gate first
                    partial(StageCallback, curriculum_ref(curriculum),
                            str(restore_from) if restoring else None),
                    OutcomeMetrics])
        .debugging(seed=seed)
    )
