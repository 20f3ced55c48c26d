"""Conversion between our arrays and the reference's JSON schema (tests/reference/README.md).

Loading validates: every malformed input raises a ValueError naming the field and the value, so a
bad state never reaches the compiled kernels.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .constants import (
    BOARD_SIZE,
    GAME_ENV_STRINGS,
    MAX_BOMBS,
    MAX_FLAMES,
    MAX_ITEMS,
    NUM_AGENTS,
    POWER_UP_CODES,
    RADIO_NUM_WORDS,
    RADIO_VOCAB_SIZE,
    STATE_BOARD_CODES,
    GameType,
    Item,
    enemies_of,
    has_radio,
    teammate_of,
)
from .observation import Observation
from .state import (
    A_ALIVE,
    A_AMMO,
    A_BLAST,
    A_COL,
    A_KICK,
    A_ROW,
    M_BOMBS,
    M_FLAMES,
    M_ITEMS,
    M_STEP,
    GameState,
    empty_state,
)


def _field(d: Mapping, key: str, where: str) -> Any:
    if not isinstance(d, Mapping):
        raise ValueError(f"{where}: expected an object, got {type(d).__name__}")
    if key not in d:
        raise ValueError(f"{where}: missing field {key!r}")
    return d[key]


def _int(value: Any, where: str, lo: int | None = None, hi: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{where}: expected an integer, got {value!r}")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise ValueError(f"{where}: value {value} outside [{lo}, {hi}]")
    return int(value)


def _bool(value: Any, where: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{where}: expected a boolean, got {value!r}")
    return bool(value)


def _cell(value: Any, where: str, size: int) -> tuple[int, int]:
    if not isinstance(value, Sequence) or len(value) != 2:
        raise ValueError(f"{where}: expected [row, col], got {value!r}")
    return _int(value[0], where, 0, size - 1), _int(value[1], where, 0, size - 1)


def _grid(value: Any, where: str, size: int) -> np.ndarray:
    try:
        arr = np.asarray(value)
    except ValueError as exc:  # ragged nested lists
        raise ValueError(f"{where}: not a {size}x{size} grid ({exc})") from None
    if arr.shape != (size, size):
        raise ValueError(f"{where}: expected shape ({size}, {size}), got {arr.shape}")
    if arr.dtype.kind == "f":
        if not np.all(arr == np.round(arr)):
            raise ValueError(f"{where}: expected whole numbers")
    elif arr.dtype.kind not in "iub":
        raise ValueError(f"{where}: expected integers, got dtype {arr.dtype}")
    return arr.astype(np.int64)


def _list(value: Any, where: str, capacity: int) -> Sequence:
    if not isinstance(value, Sequence) or isinstance(value, str):
        raise ValueError(f"{where}: expected a list, got {type(value).__name__}")
    if len(value) > capacity:
        raise ValueError(f"{where}: {len(value)} entries exceed the capacity {capacity}")
    return value


def load_state(d: Mapping, out: GameState | None = None, index: int = 0) -> GameState:
    """Fill game `index` of `out` (a new batch of one by default) from a reference state dict."""
    board = _grid(_field(d, "board", "state"), "state.board", BOARD_SIZE)
    size = board.shape[0]
    bad = sorted(set(np.unique(board).tolist()) - set(STATE_BOARD_CODES))
    if bad:
        r, c = np.argwhere(np.isin(board, bad))[0]
        raise ValueError(f"state.board: unknown item code {bad[0]} at [{r}, {c}]")
    state = out if out is not None else empty_state(1, size)
    for arr in state:
        arr[index] = 0
    state.board[index] = board
    state.meta[index, M_STEP] = _int(_field(d, "step_count", "state"), "state.step_count", 0)

    agents = _field(d, "agents", "state")
    if not isinstance(agents, Sequence) or len(agents) != NUM_AGENTS:
        raise ValueError(f"state.agents: expected {NUM_AGENTS} agents, got {agents!r:.80}")
    occupied: dict[tuple[int, int], int] = {}
    for i, a in enumerate(agents):
        where = f"state.agents[{i}]"
        if _int(_field(a, "agent_id", where), f"{where}.agent_id") != i:
            raise ValueError(f"{where}.agent_id: expected {i}, got {a['agent_id']!r}")
        r, c = _cell(_field(a, "position", where), f"{where}.position", size)
        alive = _bool(_field(a, "is_alive", where), f"{where}.is_alive")
        if alive:
            if (r, c) in occupied:
                raise ValueError(
                    f"{where}.position: agents {occupied[(r, c)]} and {i} both alive on [{r}, {c}]"
                )
            occupied[(r, c)] = i
            if board[r, c] != Item.AGENT0 + i:
                raise ValueError(
                    f"{where}.position: board holds {board[r, c]} at [{r}, {c}], not agent code "
                    f"{Item.AGENT0 + i}"
                )
        row = state.agents[index, i]
        row[A_ROW], row[A_COL], row[A_ALIVE] = r, c, alive
        row[A_AMMO] = _int(_field(a, "ammo", where), f"{where}.ammo", 0)
        row[A_BLAST] = _int(_field(a, "blast_strength", where), f"{where}.blast_strength", 1)
        row[A_KICK] = _bool(_field(a, "can_kick", where), f"{where}.can_kick")
    for code in range(Item.AGENT0, Item.AGENT0 + NUM_AGENTS):
        i = code - Item.AGENT0
        cells = np.argwhere(board == code)
        if len(cells) and not agents[i]["is_alive"]:
            raise ValueError(f"state.board: dead agent {i} is drawn at {cells[0].tolist()}")
        if len(cells) > 1:
            raise ValueError(f"state.board: agent {i} is drawn {len(cells)} times")

    bombs = _list(_field(d, "bombs", "state"), "state.bombs", MAX_BOMBS)
    for k, b in enumerate(bombs):
        where = f"state.bombs[{k}]"
        r, c = _cell(_field(b, "position", where), f"{where}.position", size)
        direction = _field(b, "moving_direction", where)
        state.bombs[index, k] = (
            r,
            c,
            _int(_field(b, "bomber_id", where), f"{where}.bomber_id", 0, NUM_AGENTS - 1),
            _int(_field(b, "life", where), f"{where}.life", 0),
            _int(_field(b, "blast_strength", where), f"{where}.blast_strength", 1),
            0 if direction is None else _int(direction, f"{where}.moving_direction", 0, 4),
        )
    flames = _list(_field(d, "flames", "state"), "state.flames", MAX_FLAMES)
    for k, f in enumerate(flames):
        where = f"state.flames[{k}]"
        r, c = _cell(_field(f, "position", where), f"{where}.position", size)
        state.flames[index, k] = (r, c, _int(_field(f, "life", where), f"{where}.life", 0, 2))
    items = _list(_field(d, "items", "state"), "state.items", MAX_ITEMS)
    for k, it in enumerate(items):
        where = f"state.items[{k}]"
        if not isinstance(it, Sequence) or len(it) != 3:
            raise ValueError(f"{where}: expected [row, col, code], got {it!r}")
        r, c = _cell(it[:2], where, size)
        code = _int(it[2], f"{where} code")
        if code not in POWER_UP_CODES:
            raise ValueError(f"{where}: item code {code} is not a power-up (6, 7 or 8)")
        state.items[index, k] = (r, c, code)
    state.meta[index, M_ITEMS] = len(items)
    state.meta[index, M_BOMBS] = len(bombs)
    state.meta[index, M_FLAMES] = len(flames)
    if "radio_from_agent" in d:
        state.radio[index] = _words_by_agent(d["radio_from_agent"])
    return state


def load_words(pair: Any, where: str) -> tuple[int, ...]:
    """One agent's two words (a state's entry, a `message`, what an agent says): [word, word],
    each an integer 0..7; a ValueError names `where` and the value."""
    if isinstance(pair, str) or not isinstance(pair, Sequence | np.ndarray) \
            or len(pair) != RADIO_NUM_WORDS:
        raise ValueError(f"{where}: expected [word, word], got {pair!r:.80}")
    return tuple(_int(w, where, 0, RADIO_VOCAB_SIZE - 1) for w in pair)


def _words_by_agent(value: Any) -> np.ndarray:
    """A state's `radio_from_agent`: four [word, word] pairs, each word 0..7."""
    where = "state.radio_from_agent"
    if not isinstance(value, Sequence) or len(value) != NUM_AGENTS:
        raise ValueError(f"{where}: expected {NUM_AGENTS} pairs of words, got {value!r:.80}")
    return np.array([load_words(pair, f"{where}[{i}]") for i, pair in enumerate(value)],
                    np.uint8).reshape(NUM_AGENTS, RADIO_NUM_WORDS)


def dump_state(state: GameState, index: int = 0, game_type: int = GameType.TEAM) -> dict:
    """Game `index` of `state` as a reference state dict (with `radio_from_agent` in TeamRadio)."""
    meta = state.meta[index]
    agents = []
    for i, row in enumerate(state.agents[index]):
        agents.append(
            {
                "agent_id": i,
                "position": [int(row[A_ROW]), int(row[A_COL])],
                "is_alive": bool(row[A_ALIVE]),
                "ammo": int(row[A_AMMO]),
                "blast_strength": int(row[A_BLAST]),
                "can_kick": bool(row[A_KICK]),
                "teammate": teammate_of(i, game_type),
                "enemies": enemies_of(i, game_type),
            }
        )
    out = {
        "step_count": int(meta[M_STEP]),
        "board": state.board[index].tolist(),
        "items": state.items[index, : meta[M_ITEMS]].tolist(),
        "agents": agents,
        "bombs": [
            {
                "position": [int(b[0]), int(b[1])],
                "bomber_id": int(b[2]),
                "life": int(b[3]),
                "blast_strength": int(b[4]),
                "moving_direction": int(b[5]) or None,
            }
            for b in state.bombs[index, : meta[M_BOMBS]]
        ],
        "flames": [
            {"position": [int(f[0]), int(f[1])], "life": int(f[2])}
            for f in state.flames[index, : meta[M_FLAMES]]
        ],
    }
    if has_radio(game_type):
        out["radio_from_agent"] = state.radio[index].tolist()
    return out


OBS_MAPS = ("board", "bomb_blast_strength", "bomb_life", "bomb_moving_direction", "flame_life")


def load_observation(d: Mapping, agent_id: int) -> Observation:
    """One agent's reference observation dict as an `Observation` with leading shape ()."""
    where = f"observation of agent {agent_id}"
    maps = {}
    for key in OBS_MAPS:
        grid = _grid(_field(d, key, where), f"{where}.{key}", BOARD_SIZE)
        if grid.min() < 0 or grid.max() > 255:
            raise ValueError(f"{where}.{key}: values outside 0..255")
        maps[key] = grid.astype(np.uint8)
    size = maps["board"].shape[0]
    alive = np.zeros(NUM_AGENTS, np.bool_)
    for code in _list(_field(d, "alive", where), f"{where}.alive", NUM_AGENTS):
        alive[_int(code, f"{where}.alive", Item.AGENT0, Item.AGENT3) - Item.AGENT0] = True
    return Observation(
        **maps,
        position=np.array(_cell(_field(d, "position", where), f"{where}.position", size), np.int32),
        # bounded to what the arrays hold (uint8 maps and features, int32 counters)
        ammo=np.int32(_int(_field(d, "ammo", where), f"{where}.ammo", 0, 255)),
        blast_strength=np.int32(
            _int(_field(d, "blast_strength", where), f"{where}.blast_strength", 0, 255)
        ),
        can_kick=np.bool_(_bool(_field(d, "can_kick", where), f"{where}.can_kick")),
        alive=alive,
        agent_id=np.int32(agent_id),
        game_type=np.int32(_int(_field(d, "game_type", where), f"{where}.game_type", 1,
                                int(max(GameType)))),
        step_count=np.int32(
            _int(_field(d, "step_count", where), f"{where}.step_count", 0, 2**31 - 1)
        ),
    )


def dump_observation(obs: Observation, message: np.ndarray | None = None) -> dict:
    """One agent's observation (leading shape ()) as a reference observation dict; in TeamRadio
    pass the words it hears (`Games.message`), which become its last field `message`."""
    agent_id, game_type = int(obs.agent_id), int(obs.game_type)
    out = {
        "alive": [Item.AGENT0 + i for i in range(NUM_AGENTS) if obs.alive[i]],
        "board": obs.board.tolist(),
        "bomb_blast_strength": obs.bomb_blast_strength.tolist(),
        "bomb_life": obs.bomb_life.tolist(),
        "bomb_moving_direction": obs.bomb_moving_direction.tolist(),
        "flame_life": obs.flame_life.tolist(),
        "game_type": game_type,
        "game_env": GAME_ENV_STRINGS[game_type],
        "position": obs.position.tolist(),
        "blast_strength": int(obs.blast_strength),
        "can_kick": bool(obs.can_kick),
        "teammate": teammate_of(agent_id, game_type),
        "ammo": int(obs.ammo),
        "enemies": enemies_of(agent_id, game_type),
        "step_count": int(obs.step_count),
    }
    out["alive"] = [int(a) for a in out["alive"]]
    if message is not None:
        out["message"] = [int(w) for w in message]
    return out
