"""One seeding rule for every game we play: match or dataset seed plus game index.

Game g of a run seeded S takes its board from child 0 of `SeedSequence([S, g])` and seat s's
random stream from child s + 1, so a game is the same whichever process plays it, in whatever
batch, and a dataset game replays exactly in the arena or through the single-game API.
"""

from __future__ import annotations

import numpy as np

from .constants import NUM_AGENTS


def game_seeds(seed: int, game: int) -> tuple[int, list[np.random.Generator]]:
    """Board seed and the four seats' generators of game `game` of a run seeded `seed`."""
    children = np.random.SeedSequence([seed, game]).spawn(1 + NUM_AGENTS)
    return int(children[0].generate_state(1)[0]), [np.random.default_rng(c) for c in children[1:]]
