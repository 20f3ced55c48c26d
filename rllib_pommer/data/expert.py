"""Expert play: 2v2 Team games of four experts, every living agent's decision recorded.

The expert is SimpleAgent (`play_games`, as in Meisheri et al. 2019) or the search agent at a
policy file's effort (`play_search_games`, agents/search.py), on all four seats. The games of a
range run in one batch (`Games` plus one batched expert call per step: for SimpleAgent the
fastest path, see agents/speed.simple_batched_run); a slot whose game ends is refilled with the
next game of the range. Game g is seeded as in the arena (`SeedSequence([seed, g]).spawn(5)`: the
board from the first child, seat s's random stream from child s + 1, from which the seat's memory
row is made as the agent's `reset` makes it), and each agent's stream lives in its own memory
row, so a game's samples depend only on (seed, g): not on the batch, its refills, the shard or
the worker that played it; and game g is the arena's game g of the same seed with the expert on
every seat.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..agents import search
from ..agents.registry import resolve_policy
from ..agents.simple import new_memory, simple_action_counts, simple_actions
from ..game.constants import NUM_ACTIONS, NUM_AGENTS, TEAM_PRESET
from ..game.engine import Games
from ..game.seeding import game_seeds
from .schema import Samples

BATCH_GAMES = 64  # games stepped together, amortising the per-step Python overhead

# rows, rng -> fresh memory rows of an expert, as a tuple of arrays with a leading row axis
NewMemory = Callable[[int, np.random.Generator], tuple]


def _search_memory(rows: int, rng: np.random.Generator) -> tuple[np.ndarray]:
    """The search agent's memory rows (one int64 array, agents/belief.py) in a 1-tuple."""
    return (search.new_memory(rows, rng),)


def reset_memory(memory: tuple, slot: int, rngs: list[np.random.Generator],
                 fresh_memory: NewMemory = new_memory) -> None:
    """Fresh memory rows for the four seats of `slot`, each made from its own generator as the
    agent's `reset` makes its one row."""
    for seat, rng in enumerate(rngs):
        for field, fresh in zip(memory, fresh_memory(1, rng), strict=True):
            field[NUM_AGENTS * slot + seat] = fresh[0]


class GameSlots:
    """`Games` whose finished slots are refilled with the next games of a range. Game g is seeded
    as in the arena and its four seats get expert memory rows made from their streams
    (`new_memory`: SimpleAgent's by default); `on_start(slot, game)` lets a caller set up more
    per game (who plays which seat)."""

    def __init__(self, seed: int, games: range, batch_games: int,
                 on_start: Callable[[int, int], None] | None = None,
                 new_memory: NewMemory = new_memory):
        self.engine = Games(min(batch_games, len(games)), TEAM_PRESET)
        slots = self.engine.num_games
        self.memory = new_memory(NUM_AGENTS * slots, np.random.default_rng(0))  # reseeded
        self.game = np.full(slots, -1, np.int64)
        self.board_seed = np.zeros(slots, np.int64)
        self._seed, self._upcoming, self._on_start = seed, iter(games), on_start
        self._new_memory = new_memory
        self._start(range(slots))

    @property
    def playing(self) -> bool:
        return bool((self.game >= 0).any())

    def active(self) -> np.ndarray:
        """(slots * 4,) rows of agents that act this step: alive, in a game not yet over."""
        return (self.engine.alive & ~self.engine.done[:, None]).ravel()

    def samples(self, rows, actions: np.ndarray, counts: np.ndarray) -> Samples:
        return Samples(rows, actions, np.repeat(self.game, NUM_AGENTS),
                       np.repeat(self.board_seed, NUM_AGENTS), counts)

    def step(self, actions: np.ndarray) -> None:
        self.engine.step(actions.reshape(-1, NUM_AGENTS))
        self._start(np.flatnonzero(self.engine.done & (self.game >= 0)))

    def _start(self, free) -> None:
        """Put the next games into `free` slots; a slot left without one keeps its finished
        game and is marked empty."""
        started = []
        for slot, game in zip(free, self._upcoming, strict=False):
            self.board_seed[slot], rngs = game_seeds(self._seed, game)
            self.game[slot] = game
            reset_memory(self.memory, slot, rngs, self._new_memory)
            if self._on_start:
                self._on_start(slot, game)
            started.append(slot)
        if started:
            self.engine.reset(self.board_seed[started], started)
        self.game[list(free)[len(started):]] = -1


def play_games(seed: int, games: range, batch_games: int = BATCH_GAMES,
               label_draws: int = 0) -> Samples:
    """Every decision of the living agents in games `games` (in play order).

    With `label_draws` > 0, each decision also carries SimpleAgent's action counts over that many
    independent draws from the same memory (`simple_action_counts`): the soft target that
    behaviour cloning learns the whole tie-breaking distribution from. The draws leave the agents'
    memories and streams alone, so the games played are the same with or without them.
    """
    slots = GameSlots(seed, games, batch_games)
    recorded: list[Samples] = []
    while slots.playing:
        active = slots.active()
        rows = slots.engine.obs.agent_rows()
        counts = (simple_action_counts(rows, slots.memory, label_draws, active) if label_draws
                  else np.zeros((len(active), NUM_ACTIONS), np.uint8))
        actions = simple_actions(rows, slots.memory, active)
        recorded.append(slots.samples(rows, actions, counts).take(np.flatnonzero(active)))
        slots.step(actions)
    return Samples.concatenate(recorded)


@dataclass(frozen=True)
class SearchExpert:
    """The search agent as the expert: the policy file's name and its effort."""

    name: str
    effort: search.Effort

    @classmethod
    def resolve(cls, name: str) -> SearchExpert:
        """The expert a policy of kind "search" describes (a name in policies/ or a file);
        ValueError naming it if it is of another kind."""
        spec = resolve_policy(name)
        if spec.kind != "search" or spec.filters or spec.words:
            raise ValueError(f"expert {name!r}: the expert is 'simple' or a policy of kind "
                             f"'search' without suffixes (search, search_fast), not a "
                             f"{spec.kind!r} policy")
        return cls(spec.name, search.Effort.from_params(spec.params, str(spec.path)))

    @property
    def effort_text(self) -> str:
        """The effort as the shards' metadata records it, "depth=2 horizon=10 recall=5"."""
        return format_effort(self.effort)


def format_effort(effort: search.Effort) -> str:
    return f"depth={effort.depth} horizon={effort.horizon} recall={effort.recall}"


def parse_effort(text: str) -> search.Effort:
    """The effort `format_effort` wrote as `text`; ValueError if it is not one."""
    try:
        values = dict(item.split("=") for item in text.split())
        return search.Effort(**{key: int(value) for key, value in values.items()})
    except (ValueError, TypeError) as exc:
        raise ValueError(f"search effort {text!r}: not 'depth=D horizon=H recall=R'") from exc


def play_search_games(seed: int, games: range, effort: search.Effort,
                      batch_games: int = BATCH_GAMES, label_draws: int = 0) -> Samples:
    """Every decision of the living agents in games `games` (in play order) of four search
    agents at `effort`: each row's action is the one its agent played.

    The agent breaks ties and near-ties (values within 1) with a draw from its seeded stream
    (docs/search.md §2). With `label_draws` > 0, each decision also carries the counts of the
    actions that many further draws pick from the same values (`search.search_decisions`): the
    agent's action distribution, the soft target. The draws come from streams of their own, so
    the games played are the same with or without them, and they cost no further search.
    """
    slots = GameSlots(seed, games, batch_games, new_memory=_search_memory)
    (memory,) = slots.memory
    recorded: list[Samples] = []
    while slots.playing:
        active = slots.active()
        rows = slots.engine.obs.agent_rows()
        actions, counts = search.search_decisions(rows, memory, effort, active, label_draws)
        recorded.append(slots.samples(rows, actions, counts).take(np.flatnonzero(active)))
        slots.step(actions)
    return Samples.concatenate(recorded)
