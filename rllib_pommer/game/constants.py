"""Codes and presets of the Pommerman game, as the reference implementation numbers them.

The integer values are part of the recorded-game schema (docs/rules.md §1,
tests/reference/README.md), so they are fixed here once and every other module imports them by name.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import IntEnum

import numpy as np


class Item(IntEnum):
    """Values stored in a board cell."""

    PASSAGE = 0
    RIGID = 1
    WOOD = 2
    BOMB = 3
    FLAMES = 4
    FOG = 5
    EXTRA_BOMB = 6
    INCR_RANGE = 7
    KICK = 8
    AGENT_DUMMY = 9
    AGENT0 = 10
    AGENT1 = 11
    AGENT2 = 12
    AGENT3 = 13


class Action(IntEnum):
    """The six actions; 1..4 are also the bomb moving directions."""

    STOP = 0
    UP = 1
    DOWN = 2
    LEFT = 3
    RIGHT = 4
    BOMB = 5


class Result(IntEnum):
    WIN = 0
    LOSS = 1
    TIE = 2
    INCOMPLETE = 3


class GameType(IntEnum):
    FFA = 1
    TEAM = 2
    TEAM_RADIO = 3


# Codes a true board holds (Fog and AgentDummy appear in observations only), and the power-ups.
STATE_BOARD_CODES = tuple(int(i) for i in Item if i not in (Item.FOG, Item.AGENT_DUMMY))
POWER_UP_CODES = (int(Item.EXTRA_BOMB), int(Item.INCR_RANGE), int(Item.KICK))

NUM_AGENTS = 4
NUM_ACTIONS = 6
MAX_AMMO = 10
BOMB_LIFE_AT_LAYING = 10
FLAME_LIFE_AT_CREATION = 2
DEFAULT_BLAST_STRENGTH = 2
DEFAULT_AMMO = 1
BOARD_SIZE = 11  # both presets' boards; board generation supports this size alone
MAX_STEPS = 800  # the step limit of both presets: a game still going then is a tie
# (row, col) displacement of each action code; Stop and Bomb do not move.
ACTION_DR = np.array([0, -1, 1, 0, 0, 0], dtype=np.int64)
ACTION_DC = np.array([0, 0, 0, -1, 1, 0], dtype=np.int64)
START_POSITIONS = ((1, 1), (9, 1), (9, 9), (1, 9))
# The `game_env` string observations carry, by game type (TeamRadio is the reference's v2 env).
GAME_ENV_STRINGS = {
    GameType.FFA: "pommerman.envs.v0:Pomme",
    GameType.TEAM: "pommerman.envs.v0:Pomme",
    GameType.TEAM_RADIO: "pommerman.envs.v2:Pomme",
}
# TeamRadio's channel (docs/rules.md §10): each step an agent may send this many words, each a
# number below the vocabulary size.
RADIO_NUM_WORDS = 2
RADIO_VOCAB_SIZE = 8

# Capacities of the fixed-shape state arrays. Bombs never share a cell, and a cell holds at most
# three flame records (created on three consecutive steps), so these bound any reachable state.
MAX_BOMBS = BOARD_SIZE * BOARD_SIZE
MAX_FLAMES = 3 * MAX_BOMBS
MAX_ITEMS = BOARD_SIZE * BOARD_SIZE


@dataclass(frozen=True)
class GameConfig:
    """A game preset: board size, wall and item counts, observability and the step limit."""

    name: str
    env_id: str
    game_type: GameType
    board_size: int = BOARD_SIZE
    num_rigid: int = 36
    num_wood: int = 36
    num_items: int = 20
    view_radius: int = -1  # -1: fully observable
    max_steps: int = MAX_STEPS

    @property
    def blast_cap(self) -> int:
        """IncrRange's cap: 'view size, or 10 if unset' (docs/rules.md §1.4)."""
        return self.view_radius if self.view_radius > 0 else 10


# The presets by name (`preset`); a preset's `game_type` is the GameType code states carry.
TEAM_PRESET = GameConfig("team", "PommeTeamCompetition-v0", GameType.TEAM, view_radius=4)
FFA_PRESET = GameConfig("ffa", "PommeFFACompetition-v0", GameType.FFA)
# TeamRadio: the Team game plus the words channel (docs/rules.md §10).
RADIO_PRESET = replace(TEAM_PRESET, name="radio", env_id="PommeRadioCompetition-v2",
                       game_type=GameType.TEAM_RADIO)
PRESETS = {p.name: p for p in (TEAM_PRESET, FFA_PRESET, RADIO_PRESET)}
CONFIG_BY_ENV_ID = {p.env_id: p for p in PRESETS.values()}


def preset(name: str) -> GameConfig:
    """The preset called `name`, or a ValueError listing the valid names."""
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown game preset {name!r}; valid: {sorted(PRESETS)}") from None


def has_teams(game_type: int) -> bool:
    """Whether the game is played in two teams, agents 0 and 2 against 1 and 3: Team and TeamRadio
    (which share every team rule: identities, end, rewards, info), not FFA."""
    return game_type == GameType.TEAM or game_type == GameType.TEAM_RADIO


# The presets played in two teams, by the name an env config's or a curriculum's `game` gives:
# the variants of the team env ("team", "radio").
TEAM_GAMES = {name: p for name, p in PRESETS.items() if has_teams(p.game_type)}


def has_radio(game_type: int) -> bool:
    """Whether agents send words (TeamRadio)."""
    return game_type == GameType.TEAM_RADIO


def teammate_of(agent_id: int, game_type: int) -> int:
    """Item code of the teammate (AgentDummy in FFA)."""
    if has_teams(game_type):
        return Item.AGENT0 + (agent_id + 2) % NUM_AGENTS
    return int(Item.AGENT_DUMMY)


def enemies_of(agent_id: int, game_type: int) -> list[int]:
    """Item codes of the enemies, in the reference's order (Team appends AgentDummy)."""
    if has_teams(game_type):
        return [Item.AGENT0 + i for i in range(NUM_AGENTS) if i % 2 != agent_id % 2] + [
            int(Item.AGENT_DUMMY)
        ]
    return [Item.AGENT0 + i for i in range(NUM_AGENTS) if i != agent_id]
