"""Expert play: 2v2 Team games of four SimpleAgents, every living agent's decision recorded.

The games of a range run in one batch (`Games` plus one batched SimpleAgent call per step, the
fastest path, see agents/speed.simple_batched_run); a slot whose game ends is refilled with the
next game of the range. Game g is seeded as in the arena (`SeedSequence([seed, g]).spawn(5)`: the
board from the first child, seat s's random stream from child s + 1), and each agent's stream
lives in its own memory row, so a game's samples depend only on (seed, g): not on the batch, its
refills, the shard or the worker that played it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..agents.simple import SimpleMemory, new_memory, simple_action_counts, simple_actions
from ..game.constants import NUM_ACTIONS, NUM_AGENTS, TEAM_PRESET
from ..game.engine import Games
from ..game.seeding import game_seeds
from .schema import Samples

BATCH_GAMES = 64  # games stepped together, amortising the per-step Python overhead


def reset_memory(memory: SimpleMemory, slot: int, rngs: list[np.random.Generator]) -> None:
    """Fresh memory rows for the four seats of `slot`, each seeded from its own generator."""
    for seat, rng in enumerate(rngs):
        for field, fresh in zip(memory, new_memory(1, rng), strict=True):
            field[NUM_AGENTS * slot + seat] = fresh[0]


class GameSlots:
    """`Games` whose finished slots are refilled with the next games of a range. Game g is seeded
    as in the arena and its four seats get SimpleAgent memory rows seeded from their streams;
    `on_start(slot, game)` lets a caller set up more per game (who plays which seat)."""

    def __init__(self, seed: int, games: range, batch_games: int,
                 on_start: Callable[[int, int], None] | None = None):
        self.engine = Games(min(batch_games, len(games)), TEAM_PRESET)
        slots = self.engine.num_games
        self.memory = new_memory(NUM_AGENTS * slots, np.random.default_rng(0))  # reseeded
        self.game = np.full(slots, -1, np.int64)
        self.board_seed = np.zeros(slots, np.int64)
        self._seed, self._upcoming, self._on_start = seed, iter(games), on_start
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
            reset_memory(self.memory, slot, rngs)
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
