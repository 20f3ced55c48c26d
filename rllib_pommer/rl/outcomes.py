"""The metrics that say how the learner really does, logged per episode on the env runners.

Per episode: the learner's true outcome (win/loss/tie of its team; in a league, also per
opponent: `learner_win_vs_<policy>`), its return under the stage's reward mode, who killed whom
(`learner_kills`: enemies its team killed; `learner_suicides` and `learner_opponent_suicides`:
agents of each team dead in their own blast; `game/kills.py`), the bombs each learner agent laid,
and the share of its actions the filters overrode. In a league, each game is also counted for
the league's gate and matchmaking book (`league_games`, `league_wins`, and per opponent
`league_games_vs_<policy>`, `league_wins_vs_`, `league_losses_vs_`: sums over the iteration;
rl/league.py reads them). They appear under `env_runners/` in the results.
"""

from __future__ import annotations

from ray.rllib.callbacks.callbacks import RLlibCallback

from ..curriculum.names import LEARNER
from ..game.kills import deaths_by_cause, kills_of_team
from .connectors import FILTERS_KEY


def learner_outcome(chunks) -> dict | None:
    """The learner's episode from its chunks, or None: `result` ("win"|"loss"|"tie" of its
    team), `return` (per learner agent, averaged where the learner is its own teammate),
    `opponent` (the opponents' module), and per game `kills`, `suicides`, `opponent_suicides`
    and `bombs` (laid per learner agent, as the engine counts them), from the final infos.

    An agent that died in an earlier chunk is absent from the later ones, so all are searched."""
    returns: dict = {}
    modules: dict = {}
    for chunk in chunks:
        for agent in chunk.agent_episodes.values():
            modules[agent.agent_id] = agent.module_id
            if agent.module_id == LEARNER:
                returns[agent.agent_id] = returns.get(agent.agent_id, 0.0) + agent.get_return()
    finals = [e.get_infos(-1) for e in chunks[-1].agent_episodes.values()]
    final = next((info for info in finals if "winners" in info), None)
    if not returns or final is None:
        return None
    seat, winners = next(iter(returns)), final["winners"]
    died, killers = final["died"], final["killers"]
    return {
        "result": "tie" if not winners else "win" if seat in winners else "loss",
        "return": sum(returns.values()) / len(returns),
        "opponent": next(module for agent, module in modules.items() if agent % 2 != seat % 2),
        "bombs": sum(final["laid"][agent] for agent in returns) / len(returns),
        "kills": kills_of_team(seat, died, killers),
        "suicides": deaths_by_cause((seat % 2, seat % 2 + 2), died, killers)["self"],
        "opponent_suicides": deaths_by_cause((1 - seat % 2, 3 - seat % 2), died,
                                             killers)["self"],
    }


class OutcomeMetrics(RLlibCallback):
    """Logs each finished episode's learner outcome (module docstring)."""

    def on_episode_end(self, *, episode, prev_episode_chunks=None, env_runner=None,
                       metrics_logger=None, **kwargs) -> None:
        outcome = learner_outcome([*(prev_episode_chunks or []), episode])
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
            metrics_logger.log_value(f"learner_{key}", float(outcome[key]), window=100)
        if league:
            metrics_logger.log_value(f"learner_kills_vs_{opponent}", float(outcome["kills"]),
                                     window=100)
        filters = list(episode.custom_data.get(FILTERS_KEY, {}).values())
        steps = sum(f.steps for f in filters)
        if steps:
            metrics_logger.log_value("learner_override_share",
                                     sum(f.overridden for f in filters) / steps, window=100)
            for name, on in filters[0].flags.items():  # one draw per episode
                metrics_logger.log_value(f"learner_{name}_on", float(on), window=100)
