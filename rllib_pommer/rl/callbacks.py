"""The curriculum in force, and the metrics that say how the learner really does.

The stage is a function of one number, the lifetime episode count over all env runners
(`env_runners/num_episodes_lifetime`), which RLlib checkpoints. So after every iteration, after a
checkpoint is loaded, after env runners are recreated (RLlib builds them from the config it was
given at the start) and when the algorithm is built, the callback recomputes the stage and pushes
all of it again (idempotent and cheap): the policy mapping on every env runner
(each runner's own config, as RLlib's `Algorithm.add_module` sets a new mapping there), reward
mode and filter probabilities on every env, and pi's freeze on every learner (requires_grad is not
checkpointed). The algorithm's own config, frozen by RLlib, is left as built: it keeps the first
stage's mapping, which nothing reads once the env runners exist (an algorithm restored from a
checkpoint's config is set to its stage whenever its state is set, by Tune or by
`Algorithm.from_checkpoint` alike), and the callback needs no state of its own beyond the
curriculum.

Each result names the stage in force from now on (`curriculum/stage`, `stage_name`) and the one
the iteration sampled and trained in (`iteration_stage_name`, and its reward mode
`iteration_reward`, which says whether the logged returns are shaped or raw); they differ on the
iteration that ends a stage.

The iteration that ends a stage asks Tune for a checkpoint (`should_checkpoint`) and names the
stage (`curriculum/ended_stage`), so the state at every stage's end is saved (training.py keeps
it apart from Tune's rotation).

Per episode the learner's true outcome (win/loss/tie of its team; in a league stage, also per
opponent: `learner_win_vs_<policy>`), its return under the stage's reward mode and the share of
its actions the filters overrode are logged; they appear under `env_runners/` in the results.
"""

from __future__ import annotations

from ray.rllib.callbacks.callbacks import RLlibCallback
from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS, NUM_EPISODES, NUM_EPISODES_LIFETIME
from ray.tune.result import SHOULD_CHECKPOINT

from .connectors import FILTERS_KEY
from .curriculum import Curriculum
from .mapping import SeatMapping
from .rl_module import LEARNER


def _push_stage(env_runner, mapping: SeatMapping, env_settings: dict) -> None:
    mapping_fn = env_runner.config.policy_mapping_fn
    if getattr(mapping_fn, "stage", None) != mapping.stage:
        env_runner.config.multi_agent(policy_mapping_fn=mapping)
    if env_runner.env is not None:  # the driver's runner has no env when remote runners exist
        for env in env_runner.env.unwrapped.envs:
            env.unwrapped.set_stage(**env_settings)


def _learner_outcome(chunks) -> tuple[str, float, str] | None:
    """("win"|"loss"|"tie" of the learner's team, the learner's return, the opponents' module)
    from an episode's chunks, or None. The return is per learner agent, averaged where the
    learner is its own teammate.

    An agent that died in an earlier chunk is absent from the later ones, so all are searched."""
    returns: dict = {}
    modules: dict = {}
    for chunk in chunks:
        for agent in chunk.agent_episodes.values():
            modules[agent.agent_id] = agent.module_id
            if agent.module_id == LEARNER:
                returns[agent.agent_id] = returns.get(agent.agent_id, 0.0) + agent.get_return()
    finals = [e.get_infos(-1) for e in chunks[-1].agent_episodes.values()]
    winners = next((info["winners"] for info in finals if "winners" in info), None)
    if not returns or winners is None:
        return None
    seat = next(iter(returns))
    result = "tie" if not winners else "win" if seat in winners else "loss"
    opponent = next(module for agent, module in modules.items() if agent % 2 != seat % 2)
    return result, sum(returns.values()) / len(returns), opponent


class CurriculumCallback(RLlibCallback):
    """Keeps the stage of `curriculum` that the lifetime episode count says is in force, on
    every env runner, env and learner, and logs the learner's true outcomes (module docstring)."""
    def __init__(self, curriculum: Curriculum):
        super().__init__()
        self.curriculum = curriculum

    def apply_stage(self, algorithm, episodes: int) -> int:
        index = self.curriculum.stage_at(episodes)
        stage = self.curriculum.stages[index]
        mapping = SeatMapping(index, stage.teammate, stage.opponent)
        env_settings = {"reward": stage.reward, "action_filter": stage.action_filter,
                        "jitter": stage.jitter}
        algorithm.env_runner_group.foreach_env_runner(
            lambda runner: _push_stage(runner, mapping, env_settings), local_env_runner=True)
        algorithm.learner_group.foreach_learner(
            lambda learner: learner.module[LEARNER].set_pi_frozen(stage.freeze_pi))
        return index

    def _lifetime_episodes(self, algorithm) -> int:
        return int(algorithm.metrics.peek((ENV_RUNNER_RESULTS, NUM_EPISODES_LIFETIME), default=0))

    def on_algorithm_init(self, *, algorithm, **kwargs) -> None:
        self.apply_stage(algorithm, self._lifetime_episodes(algorithm))
        # Every restore (Tune's `load_checkpoint`, `Algorithm.from_checkpoint`,
        # `restore_from_path`) ends in `set_state`, which brings the lifetime episode count
        # back, and only Tune's calls `on_checkpoint_loaded` after it: the stage follows
        # every set_state instead.
        set_state = algorithm.set_state

        def set_state_and_stage(state):
            set_state(state)
            self.apply_stage(algorithm, self._lifetime_episodes(algorithm))
        algorithm.set_state = set_state_and_stage

    def on_env_runners_recreated(self, *, algorithm, is_evaluation, **kwargs) -> None:
        if not is_evaluation:
            self.apply_stage(algorithm, self._lifetime_episodes(algorithm))

    def on_train_result(self, *, algorithm, result, **kwargs) -> None:
        episodes = int(result[ENV_RUNNER_RESULTS].get(NUM_EPISODES_LIFETIME, 0))
        index = self.apply_stage(algorithm, episodes)
        before = self.curriculum.stage_at(episodes - int(result[ENV_RUNNER_RESULTS].get(
            NUM_EPISODES, 0)))
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

    def on_episode_end(self, *, episode, prev_episode_chunks=None, env_runner=None,
                       metrics_logger=None, **kwargs) -> None:
        outcome = _learner_outcome([*(prev_episode_chunks or []), episode])
        if outcome is None or metrics_logger is None:
            return
        result, learner_return, opponent = outcome
        mapping = env_runner.config.policy_mapping_fn if env_runner is not None else None
        league = isinstance(getattr(mapping, "opponent", None), tuple)
        for name in ("win", "loss", "tie"):
            metrics_logger.log_value(f"learner_{name}", float(result == name), window=100)
            if league:  # and against each opponent of the league
                metrics_logger.log_value(f"learner_{name}_vs_{opponent}", float(result == name),
                                         window=100)
        metrics_logger.log_value("learner_return", learner_return, window=100)
        filters = list(episode.custom_data.get(FILTERS_KEY, {}).values())
        steps = sum(f.steps for f in filters)
        if steps:
            metrics_logger.log_value("learner_override_share",
                                     sum(f.overridden for f in filters) / steps, window=100)
            for name, on in filters[0].flags.items():  # one draw per episode
                metrics_logger.log_value(f"learner_{name}_on", float(on), window=100)
