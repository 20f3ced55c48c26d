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

In a stage marked `self_play`, the league's filled snapshot slots join the stage's opponents, and
after each iteration the learner's league games (`league_games`, `league_wins`: sums over the
iteration) go into the gate, which may fill the next slot from the learner's pi (rl/league.py);
the new member's weights go to every env runner and the mapping takes it in at once. The result's
`league` entry says how many snapshots play and where the gate's block stands. Each league game
is also counted per opponent (`league_wins_vs_<policy>`, `league_losses_vs_`, `league_games_vs_`:
sums over the iteration); under prioritized matchmaking these go into the matchmaking book on
the learner after each iteration (rl/league.py), the league's weights follow from it
(rl/matchmaking.py) and reach every env runner's mapping in place, and the result's
`matchmaking` entry gives each member's share of the coming games, estimated win rate and
decayed games. A league with an exploiter (rl/league.py) gives it a seat cycle among the members
of its self-play stages; its games against the learner go into its own gate after each
iteration (the result's `league` entry has an `exploiter` entry: its block and the slot it
filled), and its pi is frozen with the learner's in a value warm-up.

The iteration that ends a stage asks Tune for a checkpoint (`should_checkpoint`) and names the
stage (`curriculum/ended_stage`), so the state at every stage's end is saved (training.py keeps
it apart from Tune's rotation).

Per episode the learner's true outcome (win/loss/tie of its team; in a league stage, also per
opponent: `learner_win_vs_<policy>`), its return under the stage's reward mode, who killed whom
(`learner_kills`: enemies its team killed; `learner_suicides` and `opponent_suicides`: agents of
each team dead in their own blast; `game/kills.py`), the bombs each learner agent laid and the
share of its actions the filters overrode are logged; they appear under `env_runners/` in the
results.
"""

from __future__ import annotations

from ray.rllib.callbacks.callbacks import RLlibCallback
from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS, NUM_EPISODES, NUM_EPISODES_LIFETIME
from ray.tune.result import SHOULD_CHECKPOINT

from ..game.constants import Action
from ..game.kills import deaths_by_cause, kills_of_team
from .connectors import FILTERS_KEY, move_of
from .curriculum import Curriculum
from .league import (
    MATCHMAKING_MODULE,
    exploiter_step,
    gate_step,
    members,
    next_slot,
    read_book,
)
from .mapping import SeatMapping
from .matchmaking import priority
from .names import EXPLOITER
from .rl_module import LEARNER


def _count(runners: dict, key: str) -> int:
    """A counter from the env runners' results; 0 when absent or NaN (an iteration in which no
    episode ended, e.g. the first one after a restore, reports NaN)."""
    value = runners.get(key, 0)
    return 0 if value != value else int(value)


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


def _on_learner(algorithm, func):
    """`func(learner)`'s value on the (first) learner, which holds the module states that
    checkpoints save."""
    return next(iter(algorithm.learner_group.foreach_learner(func))).get()


def _push_modules(algorithm, slots) -> None:
    """The learner's copies of modules `slots` (snapshots, a restarted exploiter) onto every env
    runner. Not RLlib's weight sync, which an env runner skips when the learner's weights
    sequence number has not moved since the last sync (a slot filled after an update has the
    same number), and which ran before the callback changed them."""
    for slot in slots:
        state = _on_learner(algorithm, lambda learner, slot=slot: learner.module[slot].get_state())
        algorithm.env_runner_group.foreach_env_runner(
            lambda runner, slot=slot, state=state: runner.module[slot].set_state(state),
            local_env_runner=True)


def _learner_outcome(chunks) -> dict | None:
    """The learner's episode from its chunks, or None: `result` ("win"|"loss"|"tie" of its
    team), `return` (per learner agent, averaged where the learner is its own teammate),
    `opponent` (the opponents' module), and per game `kills`, `suicides`, `opponent_suicides`
    and `bombs` (per learner agent).

    An agent that died in an earlier chunk is absent from the later ones, so all are searched."""
    returns: dict = {}
    bombs: dict = {}
    modules: dict = {}
    for chunk in chunks:
        for agent in chunk.agent_episodes.values():
            modules[agent.agent_id] = agent.module_id
            if agent.module_id == LEARNER:
                returns[agent.agent_id] = returns.get(agent.agent_id, 0.0) + agent.get_return()
                bombs[agent.agent_id] = bombs.get(agent.agent_id, 0) + sum(
                    move_of(a) == Action.BOMB for a in agent.get_actions())
    finals = [e.get_infos(-1) for e in chunks[-1].agent_episodes.values()]
    final = next((info for info in finals if "winners" in info), None)
    if not returns or final is None:
        return None
    seat, winners = next(iter(returns)), final["winners"]
    outcome = {
        "result": "tie" if not winners else "win" if seat in winners else "loss",
        "return": sum(returns.values()) / len(returns),
        "opponent": next(module for agent, module in modules.items() if agent % 2 != seat % 2),
        "bombs": sum(bombs.values()) / len(bombs),
    }
    if "killers" in final:
        died, killers = final["died"], final["killers"]
        outcome["kills"] = kills_of_team(seat, died, killers)
        outcome["suicides"] = deaths_by_cause((seat % 2, seat % 2 + 2), died, killers)["self"]
        outcome["opponent_suicides"] = deaths_by_cause(
            (1 - seat % 2, 3 - seat % 2), died, killers)["self"]
    return outcome


class CurriculumCallback(RLlibCallback):
    """Keeps the stage of `curriculum` that the lifetime episode count says is in force, on
    every env runner, env and learner, and logs the learner's true outcomes (module docstring)."""
    def __init__(self, curriculum: Curriculum):
        super().__init__()
        self.curriculum = curriculum

    def _book(self, algorithm) -> list:
        league = self.curriculum.league
        return _on_learner(algorithm, lambda learner: read_book(learner, league))

    def _records(self, algorithm) -> dict:
        """The matchmaking book (rl/league.py): member -> Record."""
        return _on_learner(algorithm, lambda learner: learner.module[MATCHMAKING_MODULE].records())

    def _matched(self, stage) -> bool:
        """Whether `stage` plays a league that meets the learner by prioritized matchmaking."""
        league = self.curriculum.league
        return (league is not None and league.prioritized
                and (stage.self_play or isinstance(stage.opponent, tuple)))

    def _opponent(self, algorithm, stage):
        """Who the learner meets in `stage`: its opponent or league, and in a self-play stage
        also the exploiter and the filled snapshot slots."""
        if not stage.self_play:
            return stage.opponent
        return (*stage.opponents, *self._exploiter(), *members(self._book(algorithm)))

    def _priorities(self, records: dict, opponent: tuple[str, ...]) -> list[float]:
        """Each member's matchmaking weight (rl/matchmaking.py) from the book's `records`."""
        league = self.curriculum.league
        return [priority(records[name], league.priority_power, league.priority_floor)
                for name in opponent]

    def apply_stage(self, algorithm, episodes: int) -> int:
        index = self.curriculum.stage_at(episodes)
        stage = self.curriculum.stages[index]
        opponent = self._opponent(algorithm, stage)
        weights = None
        if self._matched(stage):
            weights = tuple(self._priorities(self._records(algorithm), opponent))
        mapping = SeatMapping(index, stage.teammate, opponent, weights)
        env_settings = {"reward": stage.reward, "action_filter": stage.action_filter,
                        "jitter": stage.jitter}
        algorithm.env_runner_group.foreach_env_runner(
            lambda runner: _push_stage(runner, mapping, env_settings), local_env_runner=True)
        for module_id in (LEARNER, *self._exploiter()):
            algorithm.learner_group.foreach_learner(
                lambda learner, module_id=module_id:
                learner.module[module_id].set_pi_frozen(stage.freeze_pi))
        return index

    def _exploiter(self) -> tuple[str, ...]:
        """The league's exploiter module, if it has one (league.py)."""
        league = self.curriculum.league
        return (EXPLOITER,) if league is not None and league.exploiter else ()

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
            if self.curriculum.league:
                _push_modules(algorithm, members(self._book(algorithm)))
            self.apply_stage(algorithm, self._lifetime_episodes(algorithm))
        algorithm.set_state = set_state_and_stage

    def on_env_runners_recreated(self, *, algorithm, is_evaluation, **kwargs) -> None:
        if not is_evaluation:
            self.apply_stage(algorithm, self._lifetime_episodes(algorithm))

    def _match(self, algorithm, runners: dict) -> None:
        """The iteration's results per league member into the matchmaking book."""
        results = {}
        for name in self.curriculum.league_members():
            games = _count(runners, f"league_games_vs_{name}")
            if games:
                wins, losses = (_count(runners, f"league_{key}_vs_{name}")
                                for key in ("wins", "losses"))
                results[name] = (wins, losses, games - wins - losses)
        halflife = self.curriculum.league.priority_halflife
        algorithm.learner_group.foreach_learner(
            lambda learner: learner.module[MATCHMAKING_MODULE].add(results, halflife))

    def _matchmaking(self, algorithm, opponent: tuple[str, ...]) -> dict:
        """Each member's share of the coming games, win-rate estimate and decayed games."""
        records = self._records(algorithm)
        weights = self._priorities(records, opponent)
        return {name: {"share": weight / sum(weights), "win_rate": records[name].win_rate,
                       "games": records[name].games}
                for name, weight in zip(opponent, weights, strict=True)}

    def _gate(self, algorithm, runners: dict, episodes: int) -> dict:
        """The iteration's league games into the gate, and the exploiter's games against the
        learner into its own; a filled slot goes to the env runners (and, under prioritized
        matchmaking, starts a new record), and so does a restarted exploiter."""
        league = self.curriculum.league
        wins, games = _count(runners, "league_wins"), _count(runners, "league_games")
        filled = _on_learner(
            algorithm, lambda learner: gate_step(learner, league, wins, games, episodes))
        self._new_member(algorithm, filled)
        entry = {}
        if league.exploiter:  # its wins are the learner's losses against it
            wins, games = (_count(runners, f"league_{key}_vs_{EXPLOITER}")
                           for key in ("losses", "games"))
            joined = _on_learner(algorithm, lambda learner: exploiter_step(
                learner, league, wins, games, episodes))
            self._new_member(algorithm, joined)
            if joined:
                _push_modules(algorithm, [EXPLOITER])  # restarted from the learner
            block_wins, block_games = _on_learner(
                algorithm, lambda learner: learner.module[MATCHMAKING_MODULE].exploiter.tolist())
            entry["exploiter"] = {"filled": joined, "gate_wins": block_wins,
                                  "gate_games": block_games}
        book = self._book(algorithm)
        block = next_slot(book)
        return {"snapshots": len(members(book)), "filled": filled, "gate_games": block.games,
                "gate_win_rate": block.wins / block.games if block.games else float("nan"),
                "members": list(members(book)), **entry}

    def _new_member(self, algorithm, slot: str | None) -> None:
        """A slot just filled: a new record under prioritized matchmaking, and its weights on
        every env runner."""
        if slot is None:
            return
        if self.curriculum.league.prioritized:
            algorithm.learner_group.foreach_learner(
                lambda learner: learner.module[MATCHMAKING_MODULE].forget(slot))
        _push_modules(algorithm, [slot])

    def on_train_result(self, *, algorithm, result, **kwargs) -> None:
        runners = result[ENV_RUNNER_RESULTS]
        episodes = _count(runners, NUM_EPISODES_LIFETIME)
        before = self.curriculum.stage_at(episodes - _count(runners, NUM_EPISODES))
        if self._matched(self.curriculum.stages[before]):
            self._match(algorithm, runners)  # before the gate, which may restart a record
        if self.curriculum.stages[before].self_play:
            result["league"] = self._gate(algorithm, runners, episodes)
        index = self.apply_stage(algorithm, episodes)
        stage = self.curriculum.stages[index]
        if self._matched(stage):
            result["matchmaking"] = self._matchmaking(algorithm, self._opponent(algorithm, stage))
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
        result, opponent = outcome["result"], outcome["opponent"]
        mapping = env_runner.config.policy_mapping_fn if env_runner is not None else None
        league = isinstance(getattr(mapping, "opponent", None), tuple)
        for name in ("win", "loss", "tie"):
            metrics_logger.log_value(f"learner_{name}", float(result == name), window=100)
            if league:  # and against each opponent of the league
                metrics_logger.log_value(f"learner_{name}_vs_{opponent}", float(result == name),
                                         window=100)
        if league:  # the self-play gate's and matchmaking's counts, summed over the iteration
            metrics_logger.log_value("league_games", 1, reduce="sum")
            metrics_logger.log_value("league_wins", int(result == "win"), reduce="sum")
            metrics_logger.log_value(f"league_games_vs_{opponent}", 1, reduce="sum")
            for key, name in (("wins", "win"), ("losses", "loss")):
                metrics_logger.log_value(f"league_{key}_vs_{opponent}", int(result == name),
                                         reduce="sum")
        metrics_logger.log_value("learner_return", outcome["return"], window=100)
        metrics_logger.log_value("learner_bombs", outcome["bombs"], window=100)
        for key in ("kills", "suicides", "opponent_suicides"):
            if key in outcome:
                metrics_logger.log_value(f"learner_{key}", float(outcome[key]), window=100)
                if league and key == "kills":
                    metrics_logger.log_value(f"learner_kills_vs_{opponent}",
                                             float(outcome[key]), window=100)
        filters = list(episode.custom_data.get(FILTERS_KEY, {}).values())
        steps = sum(f.steps for f in filters)
        if steps:
            metrics_logger.log_value("learner_override_share",
                                     sum(f.overridden for f in filters) / steps, window=100)
            for name, on in filters[0].flags.items():  # one draw per episode
                metrics_logger.log_value(f"learner_{name}_on", float(on), window=100)
