"""Memory for the fog: three input planes of what an agent saw before and cannot see now.

The paper's 19 planes (`features.py`) show one observation: under the fog a cell is only "fog",
and an enemy that stepped out of view is gone. A policy with memory (issue 49's lever) reads
three more planes after them, drawn from the agent's own past observations alone, kept in the
search agent's memory row (`agents/belief.py`: per cell the code, bomb and flame last seen and
when; per agent where it was last seen):

| plane | content, on fogged cells only (0 on cells in view) | values |
|---|---|---|
| 19 | each living enemy where it was last seen, for `RECALL_STEPS` | 1 - age / 11 |
| 20 | a bomb seen there, not moving, its life counted down since | life / 10 |
| 21 | the cell as last seen (burnt-out flames as passage) | (desirability + 1) / 9 |

Desirability is plane 18's (`features.DESIRABILITY`). A cell never seen is 0 on all three (a
seen power-up, of desirability 0, is 1/9 on plane 21). At a game's start every agent is known
to stand in its corner (a fresh memory's first observation says so), so plane 19 begins with
the enemies' corners. The memory advances once per observation, so one row must see every
observation of its agent's game in order: the env keeps a row per seat, the arena's
`LearnedAgent` one per agent.

A network that reads 22 planes is a policy with memory: `network.planes_of` reads it from the
weights, and a 19-plane network's weights load into a 22-plane one with the new planes' inputs
at zero (`network.load_weights`), so such a run starts as its 19-plane policy plays.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..agents.belief import (
    AGENT_BASE,
    CELLS,
    FLAMES,
    FOG,
    G_COL,
    G_ROW,
    G_SEEN,
    MEMORY_SIZE,
    P_CODE,
    P_DIR,
    P_FLAME,
    P_LIFE,
    P_SEEN,
    PASSAGE,
    remember,
)
from ..game.constants import Item
from ..game.observation import Observation
from .features import DESIRABILITY, IDENTITY_CODES, NUM_PLANES, SCALE, featurize

RECALL_PLANES = 3
MEMORY_PLANES = NUM_PLANES + RECALL_PLANES  # what a network with memory reads
RECALL_STEPS = 10  # an enemy out of view fades from plane 19 over this many steps
AGENT0 = int(Item.AGENT0)


@njit(cache=True)
def _recall_rows(board, blast, life, direction, flame, position, alive, agent_id, enemies, step,
                 memory, out):
    size = board.shape[1]
    for m in range(board.shape[0]):
        remember(board[m], blast[m], life[m], direction[m], flame[m], position[m], agent_id[m],
                 step[m], memory[m])
        row = memory[m]
        for r in range(size):
            for c in range(size):
                if board[m, r, c] != FOG:
                    continue
                p = r * size + c
                seen = row[P_SEEN * CELLS + p]
                if seen < 0:
                    continue
                age = step[m] - seen
                code = row[P_CODE * CELLS + p]
                if code == FLAMES and row[P_FLAME * CELLS + p] - age <= 0:
                    code = PASSAGE
                out[m, 2, r, c] = (DESIRABILITY[code] + 1.0) / 9.0
                bomb_life = row[P_LIFE * CELLS + p] - age
                if bomb_life > 0 and row[P_DIR * CELLS + p] == 0:
                    out[m, 1, r, c] = bomb_life / SCALE
        for k in range(enemies.shape[1]):
            enemy = enemies[m, k]
            if enemy < 0 or not alive[m, enemy]:
                continue
            base = AGENT_BASE + 4 * enemy
            r, c = row[base + G_ROW], row[base + G_COL]
            age = step[m] - row[base + G_SEEN]
            if board[m, r, c] == FOG and age <= RECALL_STEPS:
                out[m, 0, r, c] = max(out[m, 0, r, c], 1.0 - age / (RECALL_STEPS + 1.0))


def recall_planes(obs: Observation, memory: np.ndarray) -> np.ndarray:
    """float32 planes (B, 3, 11, 11) for observations (B,) (module docstring), after folding each
    observation into its agent's memory row: `memory` (B, belief.MEMORY_SIZE) int64, rows updated
    in place (`agents/belief.new_memory` gives fresh ones)."""
    board = np.ascontiguousarray(obs.board)
    rows, size = board.shape[0], board.shape[-1]
    if memory.shape != (rows, MEMORY_SIZE) or memory.dtype != np.int64:
        raise ValueError(f"memory rows {memory.shape} {memory.dtype} do not fit {rows} "
                         f"observations: want ({rows}, {MEMORY_SIZE}) int64")
    enemies = IDENTITY_CODES[obs.game_type, obs.agent_id][:, 1:3]
    enemies = np.where(enemies >= AGENT0, enemies - AGENT0, -1)
    out = np.zeros((rows, RECALL_PLANES, size, size), np.float32)
    _recall_rows(board, np.ascontiguousarray(obs.bomb_blast_strength),
                 np.ascontiguousarray(obs.bomb_life),
                 np.ascontiguousarray(obs.bomb_moving_direction),
                 np.ascontiguousarray(obs.flame_life),
                 np.ascontiguousarray(obs.position).astype(np.int64),
                 np.ascontiguousarray(obs.alive), obs.agent_id.astype(np.int64),
                 np.ascontiguousarray(enemies), obs.step_count.astype(np.int64), memory, out)
    return out


def input_planes(obs: Observation, memory: np.ndarray | None = None) -> np.ndarray:
    """The planes a network reads for observations (B,): the 19 (`features.featurize`), and with
    the agents' memory rows (folded in, `recall_planes`) the three memory planes after them."""
    planes = featurize(obs)
    if memory is None:
        return planes
    return np.concatenate([planes, recall_planes(obs, memory)], axis=1)
