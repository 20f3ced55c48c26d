"""`finish`: a policy whose moves the search agent overrules when they fall far short of its own.

Against careful teams our learned agents stand next to an enemy in three steps of four and lay
bombs that could kill, but convert a few in a hundred, where the search agent converts a quarter
(docs/campaigns.md, the second league). A `finish` policy file names another policy (`policy`,
any name or file, filters included) and a search effort; each step the inner policy picks its
move, the search agent values all six from the same observation and its own memory
(`search.search_values`), and when the search's best move is worth at least `margin` more than
the inner one it is played instead. The scale of those values (search.py) puts a kill (an enemy
left without a way out, 2,000) and the dangers the search sees (cornered 5,000, threatened 1,500,
doomed 10,000,000) above `margin`'s default of 1,000, and the hunt and room terms (tens) far
below: the search takes over to finish an enemy or to escape, and the inner policy plays the
rest. Its seat's search memory records the move actually played, as the search agent's own does.
"""

from __future__ import annotations

import numpy as np

from ..game.constants import Action
from ..game.observation import Observation
from .base import Agent
from .belief import LAST_ACTION
from .registry import PolicySpec, looks_like_path, make_agent, register_kind
from .search import Effort, new_memory, search_values

STOP = int(Action.STOP)
MARGIN = 1_000.0  # half a kill (search.KILL)


class Finisher:
    """An inner agent whose moves the search overrules by more than `margin` (module docstring)."""

    def __init__(self, inner: Agent, effort: Effort | None = None, margin: float = MARGIN):
        if not margin > 0:
            raise ValueError(f"margin must be positive, got {margin!r}")
        self.inner = inner
        self.effort = effort or Effort()
        self.margin = margin
        self.memory = new_memory(1, np.random.default_rng(0))

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        self.inner.reset(agent_id, game_type, rng)
        self.memory = new_memory(1, rng.spawn(1)[0])  # the inner agent's draws stay its own

    def act(self, obs: Observation) -> int:
        action = int(self.inner.act(obs))
        best, _, values = search_values(obs.as_row(), self.memory, self.effort)
        value = values[0]
        own = value[action] if np.isfinite(value[action]) else value[STOP]  # plays as Stop
        if value[best[0]] - own >= self.margin:
            action = int(best[0])
        self.memory[0, LAST_ACTION] = action
        return action


def from_spec(spec: PolicySpec) -> Finisher:
    """The agent a `finish` policy file describes: its `policy` (resolved from the file's folder
    when it is a path), the search effort of its keys and its `margin`."""
    inner = spec.params["policy"]
    inner_name = str(spec.file("policy")) if looks_like_path(inner) else inner
    effort = Effort.from_params({key: spec.params[key] for key in ("depth", "horizon", "recall")
                                 if key in spec.params}, str(spec.path))
    try:
        return Finisher(make_agent(inner_name), effort, float(spec.params.get("margin", MARGIN)))
    except ValueError as error:
        raise ValueError(f"policy file {spec.path}: {error}") from error


register_kind("finish", from_spec)
