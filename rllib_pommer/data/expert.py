"""Expert play: 2v2 Team games of four SimpleAgents, every living agent's decision recorded.

The games of a range run in one batch (`Games` plus one batched SimpleAgent call per step, the
fastest path, see bench.simple_batched_run); a slot whose game ends is refilled with the next game
of the range. Game g is seeded as in the arena (`SeedSequence([seed, g]).spawn(5)`: the board from
the first child, seat s's random stream from child s + 1), and each agent's stream lives in its own
memory row, so a game's samples depend only on (seed, g): not on the batch, its refills, the shard
or the worker that played it.
"""

from __future__ import annotations

import numpy as np

from ..agents.simple import SimpleMemory, new_memory, simple_action_counts, simple_actions
from ..game.constants import NUM_ACTIONS, NUM_AGENTS, TEAM
from ..game.engine import Games
from ..game.seeding import game_seeds
from .schema import Samples

BATCH_GAMES = 64  # games stepped together, amortising the per-step Python overhead


def reset_memory(memory: SimpleMemory, slot: int, rngs: list[np.random.Generator]) -> None:
    """Fresh memory rows for the four seats of `slot`, each seeded from its own generator."""
    for seat, rng in enumerate(rngs):
        for field, fresh in zip(memory, new_memory(1, rng), strict=True):
            field[NUM_AGENTS * slot + seat] = fresh[0]


def play_games(seed: int, games: range, batch_games: int = BATCH_GAMES,
               label_draws: int = 0) -> Samples:
    """Every decision of the living agents in games `games` (in play order).

    With `label_draws` > 0, each decision also carries SimpleAgent's action counts over that many
    independent draws from the same memory (`simple_action_counts`): the soft target that
    behaviour cloning learns the whole tie-breaking distribution from. The draws leave the agents'
    memories and streams alone, so the games played are the same with or without them.
    """
    engine = Games(min(batch_games, len(games)), TEAM)
    memory = new_memory(NUM_AGENTS * engine.num_games, np.random.default_rng(0))  # reseeded
    slot_game = np.full(engine.num_games, -1, np.int64)
    slot_seed = np.zeros(engine.num_games, np.int64)
    upcoming = iter(games)

    def start(slots) -> None:
        """Put the next games into `slots`; a slot left without one keeps its finished game."""
        started = []
        for slot, game in zip(slots, upcoming, strict=False):
            slot_seed[slot], rngs = game_seeds(seed, game)
            slot_game[slot] = game
            reset_memory(memory, slot, rngs)
            started.append(slot)
        if started:
            engine.reset(slot_seed[started], started)
        slot_game[list(slots)[len(started):]] = -1

    recorded: list[Samples] = []
    start(range(engine.num_games))
    while (slot_game >= 0).any():
        active = (engine.alive & ~engine.done[:, None]).ravel()
        rows = engine.obs.agent_rows()
        counts = (simple_action_counts(rows, memory, label_draws, active) if label_draws
                  else np.zeros((len(active), NUM_ACTIONS), np.uint8))
        actions = simple_actions(rows, memory, active)
        recorded.append(Samples(rows, actions, np.repeat(slot_game, NUM_AGENTS),
                                np.repeat(slot_seed, NUM_AGENTS), counts)
                        .take(np.flatnonzero(active)))
        engine.step(actions.reshape(-1, NUM_AGENTS))
        start(np.flatnonzero(engine.done & (slot_game >= 0)))
    return Samples.concatenate(recorded)
