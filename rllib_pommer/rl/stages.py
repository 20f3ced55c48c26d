"""The curriculum's stage in force on every env runner, env and learner, and a run's start from
a checkpoint.

The stage is a function of one number, the lifetime episode count over all env runners
(`env_runners/num_episodes_lifetime`), which RLlib checkpoints. So after every iteration, after a
checkpoint is loaded, after env runners are recreated (RLlib builds them from the config it was
given at the start) and when the algorithm is built, the callback recomputes the stage and pushes
all of it again (idempotent and cheap): the policy mapping on every env runner (each runner's own
config, as RLlib's `Algorithm.add_module` sets a new mapping there), with the league's members
and matchmaking weights (rl/league.py), reward mode and filter probabilities on every env, and
pi's freeze on every learner, learner actors included (requires_grad is not checkpointed). The
algorithm's own config, frozen by RLlib, keeps the first stage's mapping, which nothing reads
once the env runners exist.

The callback is built from plain data, the curriculum's name or file (as the run folder's
`curriculum.json` notes it) and the checkpoint a resumed run starts from: that is all a run's
saved config holds of it. A run started `restore_from` a checkpoint loads its state when the
algorithm is built (RLlib's `restore_from_path`: weights, optimizer, league book, counters and
iteration), so a resumed run is a new Tune trial that carries on where the checkpoint stood.

Each result names the stage in force from now on (`curriculum/stage`, `stage_name`) and the one
the iteration sampled and trained in (`iteration_stage_name`, and its reward mode
`iteration_reward`, which says whether the logged returns are shaped or raw); they differ on the
iteration that ends a stage. That iteration also asks Tune for a checkpoint (`should_checkpoint`)
and names the stage (`curriculum/ended_stage`), so the state at every stage's end is saved
(launch/tune_callbacks.py keeps it apart from Tune's rotation).
"""

from __future__ import annotations

from ray.rllib.callbacks.callbacks import RLlibCallback
from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS, NUM_EPISODES, NUM_EPISODES_LIFETIME
from ray.tune.result import SHOULD_CHECKPOINT

from ..curriculum.curriculum import load_curriculum
from ..curriculum.mapping import SeatMapping
from ..curriculum.names import LEARNER
from .league import (
    count,
    exploiter_of,
    filled_slots,
    league_opponent,
    league_weights,
    module_of,
    push_modules,
)


def _push_stage(env_runner, mapping: SeatMapping, env_settings: dict) -> None:
    mapping_fn = env_runner.config.policy_mapping_fn
    if (getattr(mapping_fn, "stage", None), getattr(mapping_fn, "opponent", None)) != (
            mapping.stage, mapping.opponent):
        env_runner.config.multi_agent(policy_mapping_fn=mapping)
    else:  # the same league: new weights, the seat cycle and the turns' order go on
        mapping_fn.weights = mapping.weights
    if env_runner.env is not None:  # the driver's runner has no env when remote runners exist
        for env in env_runner.env.unwrapped.envs:
            env.unwrapped.set_stage(**env_settings)


def lifetime_episodes(algorithm) -> int:
    return int(algorithm.metrics.peek((ENV_RUNNER_RESULTS, NUM_EPISODES_LIFETIME), default=0))


class StageCallback(RLlibCallback):
    """Keeps the stage of the curriculum `curriculum` (a shipped name or a file) that the
    lifetime episode count says is in force (module docstring); `restore_from`, a checkpoint
    the algorithm loads when it is built."""

    def __init__(self, curriculum: str, restore_from: str | None = None):
        super().__init__()
        self.curriculum = load_curriculum(curriculum)
        self.restore_from = restore_from

    def apply_stage(self, algorithm, episodes: int) -> int:
        index = self.curriculum.stage_at(episodes)
        stage = self.curriculum.stages[index]
        opponent = league_opponent(algorithm, self.curriculum, stage)
        mapping = SeatMapping(index, stage.teammate, opponent,
                              league_weights(algorithm, self.curriculum, stage, opponent))
        env_settings = {"reward": stage.reward, "action_filter": stage.action_filter,
                        "jitter": stage.jitter}
        algorithm.env_runner_group.foreach_env_runner(
            lambda runner: _push_stage(runner, mapping, env_settings), local_env_runner=True)
        for module_id in (LEARNER, *exploiter_of(self.curriculum)):
            algorithm.learner_group.foreach_learner(
                lambda learner, module_id=module_id:
                module_of(learner, module_id).set_pi_frozen(stage.freeze_pi))
        return index

    def on_algorithm_init(self, *, algorithm, **kwargs) -> None:
        # Every restore (Tune's `load_checkpoint`, `Algorithm.from_checkpoint`,
        # `restore_from_path`) ends in `set_state`, which brings the lifetime episode count
        # back, and only Tune's calls `on_checkpoint_loaded` after it: the stage follows
        # every set_state instead.
        set_state = algorithm.set_state

        def set_state_and_stage(state):
            set_state(state)
            push_modules(algorithm, filled_slots(algorithm, self.curriculum))
            self.apply_stage(algorithm, lifetime_episodes(algorithm))
        algorithm.set_state = set_state_and_stage
        if self.restore_from:
            algorithm.restore_from_path(self.restore_from)  # ends in set_state_and_stage
        else:
            self.apply_stage(algorithm, lifetime_episodes(algorithm))

    def on_env_runners_recreated(self, *, algorithm, is_evaluation, **kwargs) -> None:
        if not is_evaluation:
            self.apply_stage(algorithm, lifetime_episodes(algorithm))

    def on_train_result(self, *, algorithm, result, **kwargs) -> None:
        runners = result[ENV_RUNNER_RESULTS]
        episodes = count(runners, NUM_EPISODES_LIFETIME)
        before = self.curriculum.stage_at(episodes - count(runners, NUM_EPISODES))
        index = self.apply_stage(algorithm, episodes)
        finished = episodes >= self.curriculum.total_episodes  # the run stops after this one
        ended = self.curriculum.stages[before].name if before != index or finished else None
        if ended:
            result[SHOULD_CHECKPOINT] = True  # Tune saves the state at the stage's end
        result["curriculum"] = {
            "stage": index,  # in force from now on
            "stage_name": self.curriculum.stages[index].name,
            "iteration_stage_name": self.curriculum.stages[before].name,  # this one sampled in
            "iteration_reward": self.curriculum.stages[before].reward,  # its returns' kind
            "episodes": episodes,
            "stage_end_episodes": self.curriculum.stage_end(index),
            "total_episodes": self.curriculum.total_episodes,
            "pi_frozen": self.curriculum.stages[index].freeze_pi,
            "ended_stage": f"{before + 1}-{ended}" if ended else None,
        }
