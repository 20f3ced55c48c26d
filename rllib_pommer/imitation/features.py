"""The paper's 19 input planes (Table 1), computed from our `Observation` arrays.

One featurizer serves behaviour cloning, the RLlib module, the arena and serving, so a policy sees
the same input everywhere. It works on any leading shape: (B,) rows give (B, 19, 11, 11).

| plane | content | values |
|---|---|---|
| 0-8 | one-hot board: passage, rigid, wood, bomb, flames, fog, extra-bomb, range, kick | 0/1 |
| 9 | own position (from `position`, so it is set even where the board shows a bomb) | 0/1 |
| 10 | teammate's cell, where visible (empty in FFA) | 0/1 |
| 11, 12 | first and second enemy's cells (in `enemies` order), where visible | 0/1 |
| 13 | own ammo, broadcast | ammo / 10 |
| 14 | own blast strength, broadcast | strength / 10 |
| 15 | own kick ability, broadcast | 0/1 |
| 16 | bomb blast strength at visible bombs | strength / 10 |
| 17 | bomb remaining life at visible bombs | life / 10 |
| 18 | desirability of each cell (values below) | value / 8 |

Desirability uses the paper's values: power-up 0, wood 1, passage 2, fog 3, enemy 4, rigid 5,
teammate 6, bomb 7, flames 8; the agent's own cell counts as passage.

Agents are drawn over bombs on the board, so a bomb under an agent shows only in planes 16-17.
Ammo and blast strength are scaled by 10, their largest possible value (the ammo cap, and the FFA
range cap). TeamRadio observations give the same planes as Team ones (its teams are Team's).

In TeamRadio an agent also hears its teammate's two words (`message`, docs/rules.md §10);
`message_features` gives them as a one-hot (2, 8) block, the radio network's second input
(`network.RadioNet`).
"""

from __future__ import annotations

import numpy as np

from ..game.constants import (
    RADIO_VOCAB_SIZE,
    GameType,
    Item,
    enemies_of,
    teammate_of,
)
from ..game.observation import Observation

NUM_PLANES = 19
BOARD_ONE_HOT = (Item.PASSAGE, Item.RIGID, Item.WOOD, Item.BOMB, Item.FLAMES, Item.FOG,
                 Item.EXTRA_BOMB, Item.INCR_RANGE, Item.KICK)
BOARD_CODES = np.array(BOARD_ONE_HOT)[:, None, None]  # planes 0-8 in one comparison
SCALE = 10.0
# Desirability of each board code (paper Table 1), before dividing by 8; agents are set apart.
DESIRABILITY = np.zeros(14, np.float32)
for _code, _value in ((Item.EXTRA_BOMB, 0), (Item.INCR_RANGE, 0), (Item.KICK, 0), (Item.WOOD, 1),
                      (Item.PASSAGE, 2), (Item.FOG, 3), (Item.RIGID, 5), (Item.BOMB, 7),
                      (Item.FLAMES, 8)):
    DESIRABILITY[_code] = _value
ENEMY_DESIRABILITY, TEAMMATE_DESIRABILITY, OWN_DESIRABILITY = 4, 6, 2


def _identity_table() -> np.ndarray:
    """[game_type, agent_id] -> board codes of teammate, first enemy, second enemy (-1: none)."""
    table = np.full((max(GameType) + 1, 4, 3), -1, np.int64)
    for game_type in GameType:
        for agent in range(4):
            mate = teammate_of(agent, game_type)
            table[game_type, agent] = (mate if mate != Item.AGENT_DUMMY else -1,
                                       *enemies_of(agent, game_type)[:2])
    return table


IDENTITY_CODES = _identity_table()
WORD_ONE_HOT = np.eye(RADIO_VOCAB_SIZE, dtype=np.float32)


def featurize(obs: Observation) -> np.ndarray:
    """float32 planes (..., 19, 11, 11) for observations of any leading shape. A few whole-block
    numpy operations rather than one per plane: the envs call it on every step."""
    board = obs.board.astype(np.int64)
    lead = board.shape[:-2]
    out = np.empty(lead + (NUM_PLANES,) + board.shape[-2:], np.float32)
    out[..., :9, :, :] = board[..., None, :, :] == BOARD_CODES
    rows = np.arange(board.shape[-2])[:, None]
    cols = np.arange(board.shape[-1])[None, :]
    own = (rows == obs.position[..., 0, None, None]) & (cols == obs.position[..., 1, None, None])
    out[..., 9, :, :] = own
    # teammate, first enemy, second enemy: agent codes (-1, never on the board, for none)
    codes = IDENTITY_CODES[obs.game_type, obs.agent_id]
    identities = board[..., None, :, :] == codes[..., :, None, None]
    out[..., 10:13, :, :] = identities
    scalars = np.stack([obs.ammo / SCALE, obs.blast_strength / SCALE, obs.can_kick], axis=-1)
    out[..., 13:16, :, :] = scalars[..., None, None]
    out[..., 16, :, :] = obs.bomb_blast_strength / SCALE
    out[..., 17, :, :] = obs.bomb_life / SCALE
    desirability = DESIRABILITY[np.minimum(board, 13)]
    desirability[identities[..., 1, :, :] | identities[..., 2, :, :]] = ENEMY_DESIRABILITY
    desirability[identities[..., 0, :, :]] = TEAMMATE_DESIRABILITY
    desirability[own] = OWN_DESIRABILITY
    out[..., 18, :, :] = desirability / 8.0
    return out


def message_features(message) -> np.ndarray:
    """float32 one-hot words (..., 2, 8) of messages (..., 2) of words 0..7 (TeamRadio's
    `message`: the teammate's two words)."""
    return WORD_ONE_HOT[np.asarray(message, np.int64)]
