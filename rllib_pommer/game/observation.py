"""Per-agent observations in one agreed array form.

Every consumer (SimpleAgent and the other scripted agents, the action filter, the 19-plane
featurizer, datasets, serving) reads this form. Each field has the same leading shape: (N, 4) when
the engine emits the four agents of N games, () for one agent's observation. The content is the
reference observation dict (docs/rules.md §5), with the float maps stored as small integers.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .constants import BOARD_SIZE, NUM_AGENTS


class Observation(NamedTuple):
    """One agent's view (or a batch of them).

    board:                 (..., S, S) uint8; cells outside the view are Fog (5).
    bomb_blast_strength:   (..., S, S) uint8; visible bombs only.
    bomb_life:             (..., S, S) uint8; 9..1 at visible bombs.
    bomb_moving_direction: (..., S, S) uint8; 1..4 at visible moving bombs.
    flame_life:            (..., S, S) uint8; flame life + 1 (3, 2, 1) at visible flames.
    position:              (..., 2) int32 [row, col]; a dead agent keeps its death cell.
    ammo, blast_strength:  (...) int32.
    can_kick:              (...) bool.
    alive:                 (..., 4) bool, by agent id; never fogged (as in the reference).
    agent_id:              (...) int32; teammate and enemies follow from it and `game_type`.
    game_type:             (...) int32; 2 Team, 1 FFA.
    step_count:            (...) int32.
    """

    board: np.ndarray
    bomb_blast_strength: np.ndarray
    bomb_life: np.ndarray
    bomb_moving_direction: np.ndarray
    flame_life: np.ndarray
    position: np.ndarray
    ammo: np.ndarray
    blast_strength: np.ndarray
    can_kick: np.ndarray
    alive: np.ndarray
    agent_id: np.ndarray
    game_type: np.ndarray
    step_count: np.ndarray

    def select(self, *index) -> Observation:
        """The observation(s) at a leading index, e.g. `obs.select(n, agent)` for one agent."""
        return Observation(*(field[index] for field in self))

    def as_row(self) -> Observation:
        """One agent's observation (leading shape ()) as a batch of one row (leading shape (1,)),
        for the batched deciders; scalar fields become arrays of one."""
        return Observation(*(np.asarray(field)[None] for field in self))

    def agent_rows(self) -> Observation:
        """The (N, 4, ...) observations of N games as (N * 4, ...) rows (views, no copy)."""
        return Observation(*(f.reshape((-1,) + f.shape[2:]) for f in self))


def empty_observations(num_games: int, board_size: int = BOARD_SIZE) -> Observation:
    """Zeroed observation arrays for the four agents of `num_games` games."""
    lead = (num_games, NUM_AGENTS)
    plane = lead + (board_size, board_size)
    return Observation(
        board=np.zeros(plane, np.uint8),
        bomb_blast_strength=np.zeros(plane, np.uint8),
        bomb_life=np.zeros(plane, np.uint8),
        bomb_moving_direction=np.zeros(plane, np.uint8),
        flame_life=np.zeros(plane, np.uint8),
        position=np.zeros(lead + (2,), np.int32),
        ammo=np.zeros(lead, np.int32),
        blast_strength=np.zeros(lead, np.int32),
        can_kick=np.zeros(lead, np.bool_),
        alive=np.zeros(lead + (NUM_AGENTS,), np.bool_),
        agent_id=np.broadcast_to(np.arange(NUM_AGENTS, dtype=np.int32), lead).copy(),
        game_type=np.zeros(lead, np.int32),
        step_count=np.zeros(lead, np.int32),
    )
