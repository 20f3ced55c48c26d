"""SimpleAgent, the reference's scripted baseline, compiled, exact to docs/rules.md §6.

The reference agent is a Python rule list over dicts and queues; here one `njit` kernel decides for
one agent from plain arrays (board, bomb strengths, own stats, memory, random stream), and a
batched kernel loops it over many rows so an arena can decide for thousands of games per call.
Every search order, tie-break and random call of §6 is kept, so the same observations and the same
random draws give the reference's decision. The only change is the random source: Python's global
Mersenne Twister is replaced by one splitmix64 stream per agent (see `rng.py`); `random()` maps to
`next_uniform` and `random.choice(list)` to one `next_below(len(list))` draw, singletons included.

Board cells are addressed by flat index `row * size + col`; -1 stands for "None".
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ..game.constants import ACTION_DC, ACTION_DR, NUM_ACTIONS, Action, GameType, Item, has_teams
from ..game.observation import Observation
from .rng import next_below, next_u64, next_uniform, seed_states

RECENT_LENGTH = 6
SEARCH_DEPTH = 10
UNREACHED = 1 << 30

STOP, UP, DOWN, LEFT, RIGHT, BOMB = (int(a) for a in Action)
PASSAGE, RIGID, WOOD, FLAMES, FOG = (
    int(i) for i in (Item.PASSAGE, Item.RIGID, Item.WOOD, Item.FLAMES, Item.FOG)
)
EXTRA_BOMB, INCR_RANGE, KICK = int(Item.EXTRA_BOMB), int(Item.INCR_RANGE), int(Item.KICK)
AGENT_DUMMY, AGENT0 = int(Item.AGENT_DUMMY), int(Item.AGENT0)
TEAM_GAME = int(GameType.TEAM)
_has_teams = njit(inline="always")(has_teams)

# Direction orders of the different routines (docs/rules.md §8 item 17).
NEIGHBOUR_ORDER = np.array([UP, DOWN, LEFT, RIGHT], np.int64)
ON_BOMB_ORDER = np.array([RIGHT, LEFT, UP, DOWN], np.int64)
WANDER_ORDER = np.array([STOP, LEFT, RIGHT, UP, DOWN], np.int64)
POWER_UPS = np.array([EXTRA_BOMB, INCR_RANGE, KICK], np.int64)
WOODS = np.array([WOOD], np.int64)


class SimpleMemory(NamedTuple):
    """What SimpleAgent remembers between decisions, one row per agent.

    recent:     (M, 6, 2) int32 cells where the wander rule last fired, oldest first.
    recent_len: (M,) int32 number of valid entries in `recent`.
    prev_dir:   (M,) int32 last direction of the approach-enemy rule; 0 means None.
    rng:        (M,) uint64 splitmix64 state of each agent's random stream.
    """

    recent: np.ndarray
    recent_len: np.ndarray
    prev_dir: np.ndarray
    rng: np.ndarray


def new_memory(m: int, rng: np.random.Generator) -> SimpleMemory:
    """Fresh memory for `m` agents, their random streams seeded from `rng`."""
    return SimpleMemory(
        recent=np.zeros((m, RECENT_LENGTH, 2), np.int32),
        recent_len=np.zeros(m, np.int32),
        prev_dir=np.zeros(m, np.int32),
        rng=seed_states(rng, m),
    )


@njit(cache=True)
def _passable(value: int, is_enemy: np.ndarray) -> bool:
    """docs/rules.md §6.2: an agent, a power-up or Passage, and not an enemy."""
    walkable = value == PASSAGE or EXTRA_BOMB <= value <= KICK or AGENT0 <= value <= AGENT0 + 3
    return walkable and not is_enemy[value]


@njit(cache=True)
def _enemy_mask(agent_id: int, game_type: int) -> np.ndarray:
    """is_enemy[code] for every uint8 code, the enemies being those of `constants.enemies_of`."""
    is_enemy = np.zeros(256, np.bool_)
    teams = _has_teams(game_type)
    for other in range(4):
        if teams:
            is_enemy[AGENT0 + other] = other % 2 != agent_id % 2
        else:
            is_enemy[AGENT0 + other] = other != agent_id
    is_enemy[AGENT_DUMMY] = teams
    return is_enemy


@njit(cache=True)
def _search(board, me, is_enemy, rng, row):
    """The depth-10 BFS of docs/rules.md §6.3, with `random() < 0.5` tie-breaks in BFS order.

    Returns (is_node, dist, prev): non-nodes and unreached nodes have dist UNREACHED.
    """
    size = board.shape[0]
    mr, mc = me // size, me % size
    is_node = np.zeros((size, size), np.bool_)
    dist = np.full((size, size), UNREACHED, np.int64)
    prev = np.full((size, size), -1, np.int64)
    # QUIRK: the exclusive upper bound skips the far row/col when the agent is on row/col 0.
    for r in range(max(0, mr - SEARCH_DEPTH), min(size, mr + SEARCH_DEPTH)):
        for c in range(max(0, mc - SEARCH_DEPTH), min(size, mc + SEARCH_DEPTH)):
            value = board[r, c]
            hidden_or_blocked = value == FOG or value == RIGID or value == FLAMES  # noqa: SIM109
            if abs(r - mr) + abs(c - mc) <= SEARCH_DEPTH and not hidden_or_blocked:
                is_node[r, c] = True
    is_node[mr, mc] = True  # only matters for malformed boards; the agent's own code is a node
    dist[mr, mc] = 0
    queue = np.empty(size * size, np.int64)
    queue[0] = me
    head, tail = 0, 1
    while head < tail:
        cell = queue[head]
        head += 1
        r, c = cell // size, cell % size
        if not _passable(board[r, c], is_enemy):
            continue
        step_dist = dist[r, c] + 1
        for k in range(4):
            direction = NEIGHBOUR_ORDER[k]
            nr, nc = r + ACTION_DR[direction], c + ACTION_DC[direction]
            if nr < 0 or nr >= size or nc < 0 or nc >= size or not is_node[nr, nc]:
                continue
            if step_dist < dist[nr, nc]:
                dist[nr, nc] = step_dist
                prev[nr, nc] = cell
                queue[tail] = nr * size + nc
                tail += 1
            elif step_dist == dist[nr, nc] and next_uniform(rng, row) < 0.5:
                prev[nr, nc] = cell
    return is_node, dist, prev


@njit(cache=True)
def _nearest(board, is_node, dist, codes, radius) -> int:
    """docs/rules.md §6.3 `nearest`: the LAST candidate (types in order, cells row-major) at minimal
    distance <= radius, as a flat cell index, or -1."""
    size = board.shape[0]
    best_dist = 0
    for r in range(size):
        for c in range(size):
            if is_node[r, c]:
                best_dist = max(best_dist, dist[r, c])
    best = -1
    for k in range(codes.shape[0]):
        for r in range(size):
            for c in range(size):
                if is_node[r, c] and board[r, c] == codes[k]:
                    d = dist[r, c]
                    if d <= radius and d <= best_dist:
                        best = r * size + c
                        best_dist = d
    return best


@njit(cache=True)
def _first_step(target, me, prev, size) -> int:
    """Direction of the first move on the recorded path from `me` to `target`; -1 for None."""
    cell = target
    while cell >= 0 and prev[cell // size, cell % size] != me:
        cell = prev[cell // size, cell % size]
    if cell < 0:  # target is `me` itself or off the search tree (malformed boards only)
        return -1
    dr, dc = cell // size - me // size, cell % size - me % size
    for direction in range(UP, RIGHT + 1):
        if ACTION_DR[direction] == dr and ACTION_DC[direction] == dc:
            return direction
    return -1


@njit(cache=True)
def _in_bomb_line(r, c, bomb_cells, bomb_strengths, size) -> bool:
    """`filter_unsafe`'s test: a bomb shares the row or column within its strength (no walls)."""
    for k in range(bomb_cells.shape[0]):
        br, bc, strength = bomb_cells[k] // size, bomb_cells[k] % size, bomb_strengths[k]
        if (r == br and abs(bc - c) <= strength) or (c == bc and abs(br - r) <= strength):
            return True
    return False


@njit(cache=True)
def _maybe_bomb(board, is_node, dist, me, ammo, blast_strength) -> bool:
    """§6.4: some reached Passage is farther than own strength or off own row and column."""
    if ammo < 1:
        return False
    size = board.shape[0]
    mr, mc = me // size, me % size
    for r in range(size):
        for c in range(size):
            if not is_node[r, c] or board[r, c] != PASSAGE or dist[r, c] == UNREACHED:
                continue
            if dist[r, c] > blast_strength or (r != mr and c != mc):
                return True
    return False


@njit(cache=True)
def _stuck(board, is_enemy, me, start, blast_range) -> bool:
    """§6.4 `stuck`: every cell reachable from `start` (with `me` now a bomb) lies on its row or
    column within `blast_range`."""
    size = board.shape[0]
    sr, sc = start // size, start % size
    seen = np.zeros((size, size), np.bool_)
    seen[sr, sc] = True
    queue = np.empty(size * size, np.int64)
    queue[0] = start
    head, tail = 0, 1
    while head < tail:
        cell = queue[head]
        head += 1
        r, c = cell // size, cell % size
        if (r != sr and c != sc) or abs(r - sr) + abs(c - sc) > blast_range:
            return False
        for k in range(4):
            direction = NEIGHBOUR_ORDER[k]
            nr, nc = r + ACTION_DR[direction], c + ACTION_DC[direction]
            if nr < 0 or nr >= size or nc < 0 or nc >= size or seen[nr, nc]:
                continue
            if nr * size + nc == me or not _passable(board[nr, nc], is_enemy):
                continue
            seen[nr, nc] = True
            queue[tail] = nr * size + nc
            tail += 1
    return True


@njit(cache=True)
def _add_unsafe(direction, strength, unsafe_range, unsafe_order) -> None:
    """Insert or raise `direction` in the unsafe map: `unsafe_range` by direction (0 = absent),
    `unsafe_order` its keys in first-insertion order."""
    if unsafe_range[direction] == 0:
        unsafe_order[np.count_nonzero(unsafe_range)] = direction
    unsafe_range[direction] = max(unsafe_range[direction], strength)


@njit(cache=True)
def _safe_directions(board, is_enemy, me, unsafe_order, num_unsafe, unsafe_range, out) -> int:
    """docs/rules.md §6.4 `find_safe_directions`, cases A and B; fills `out`, returns the count."""
    size = board.shape[0]
    mr, mc = me // size, me % size
    if num_unsafe == 4:
        for k in range(4):
            direction = unsafe_order[k]
            nr, nc = mr + ACTION_DR[direction], mc + ACTION_DC[direction]
            if nr < 0 or nr >= size or nc < 0 or nc >= size:
                continue
            if not _passable(board[nr, nc], is_enemy):  # `me` (now a bomb) is never a neighbour
                continue
            if not _stuck(board, is_enemy, me, nr * size + nc, unsafe_range[direction]):
                out[0] = direction
                return 1
        out[0] = STOP
        return 1
    count = 0
    off_board = np.zeros(5, np.bool_)
    for k in range(4):
        direction = NEIGHBOUR_ORDER[k]
        nr, nc = mr + ACTION_DR[direction], mc + ACTION_DC[direction]
        if nr < 0 or nr >= size or nc < 0 or nc >= size:
            off_board[direction] = True
            continue
        if unsafe_range[direction] > 0:
            continue
        if _passable(board[nr, nc], is_enemy) or board[nr, nc] == FOG:
            out[count] = direction
            count += 1
    if count == 0:
        for k in range(num_unsafe):
            if not off_board[unsafe_order[k]]:
                out[count] = unsafe_order[k]
                count += 1
    if count == 0:
        out[0] = STOP
        count = 1
    return count


@njit(cache=True)
def _wander(board, is_enemy, me, bomb_cells, bomb_strengths, recent, recent_len, row, rng) -> int:
    """Rules R7/R8: a random safe, passable, not recently visited move; remembers `me`."""
    size = board.shape[0]
    mr, mc = me // size, me % size
    valid = np.empty(5, np.int64)
    num_valid = 0
    for k in range(5):
        direction = WANDER_ORDER[k]
        nr, nc = mr + ACTION_DR[direction], mc + ACTION_DC[direction]
        if nr < 0 or nr >= size or nc < 0 or nc >= size or not _passable(board[nr, nc], is_enemy):
            continue
        if not _in_bomb_line(nr, nc, bomb_cells, bomb_strengths, size):
            valid[num_valid] = direction
            num_valid += 1
    fresh = np.empty(5, np.int64)
    num_fresh = 0
    for k in range(num_valid):
        nr, nc = mr + ACTION_DR[valid[k]], mc + ACTION_DC[valid[k]]
        visited = False
        for j in range(recent_len[row]):
            if recent[row, j, 0] == nr and recent[row, j, 1] == nc:
                visited = True
        if not visited:
            fresh[num_fresh] = valid[k]
            num_fresh += 1
    if num_fresh == 0:
        fresh, num_fresh = valid, num_valid
    choices = np.empty(5, np.int64)
    num_choices = 0
    for k in range(num_fresh):
        if num_fresh == 1 or fresh[k] != STOP:
            choices[num_choices] = fresh[k]
            num_choices += 1
    if num_choices == 0:
        choices[0] = STOP
        num_choices = 1
    if recent_len[row] == RECENT_LENGTH:
        for k in range(RECENT_LENGTH - 1):  # a loop: slice copies cost seconds of compile time
            recent[row, k, 0] = recent[row, k + 1, 0]
            recent[row, k, 1] = recent[row, k + 1, 1]
        recent_len[row] -= 1
    recent[row, recent_len[row], 0] = mr
    recent[row, recent_len[row], 1] = mc
    recent_len[row] += 1
    return choices[next_below(rng, row, num_choices)]


@njit(cache=True)
def decide(
    board,
    bomb_blast_strength,
    position,
    ammo,
    blast_strength,
    agent_id,
    game_type,
    recent,
    recent_len,
    prev_dir,
    rng,
    row,
) -> int:
    """One SimpleAgent decision (docs/rules.md §6.5, R1..R8) from one agent's observation arrays.

    The memory arrays are batched; `row` selects this agent's entry, which is updated in place.
    """
    size = board.shape[0]
    mr, mc = int(position[0]), int(position[1])
    me = mr * size + mc
    is_enemy = _enemy_mask(agent_id, game_type)
    enemies = np.empty(4, np.int64)  # in `constants.enemies_of` order: ids ascending, then dummy
    num_enemies = 0
    for code in (AGENT0, AGENT0 + 1, AGENT0 + 2, AGENT0 + 3, AGENT_DUMMY):
        if is_enemy[code]:
            enemies[num_enemies] = code
            num_enemies += 1
    enemies = enemies[:num_enemies]

    is_node, dist, prev = _search(board, me, is_enemy, rng, row)

    num_bombs = 0
    bomb_cells = np.empty(size * size, np.int64)
    bomb_strengths = np.empty(size * size, np.int64)
    for r in range(size):
        for c in range(size):
            if bomb_blast_strength[r, c] > 0:
                bomb_cells[num_bombs] = r * size + c
                bomb_strengths[num_bombs] = bomb_blast_strength[r, c]
                num_bombs += 1
    bomb_cells = bomb_cells[:num_bombs]
    bomb_strengths = bomb_strengths[:num_bombs]

    # Danger: directions toward bombs whose path distance is within their strength.
    unsafe_range = np.zeros(5, np.int64)
    unsafe_order = np.empty(4, np.int64)
    for k in range(num_bombs):
        br, bc, strength = bomb_cells[k] // size, bomb_cells[k] % size, bomb_strengths[k]
        if not is_node[br, bc] or dist[br, bc] > strength:
            continue
        if br == mr and bc == mc:
            for j in range(4):
                _add_unsafe(ON_BOMB_ORDER[j], strength, unsafe_range, unsafe_order)
        elif br == mr:
            direction = RIGHT if bc > mc else LEFT
            _add_unsafe(direction, strength, unsafe_range, unsafe_order)
        elif bc == mc:
            direction = DOWN if br > mr else UP
            _add_unsafe(direction, strength, unsafe_range, unsafe_order)

    # R1: escape.
    num_unsafe = np.count_nonzero(unsafe_range)
    if num_unsafe > 0:
        safe = np.empty(4, np.int64)
        count = _safe_directions(board, is_enemy, me, unsafe_order, num_unsafe, unsafe_range, safe)
        return safe[next_below(rng, row, count)]

    # R2: bomb an adjacent enemy.
    adjacent_enemy = False
    for k in range(num_enemies):
        for r in range(size):
            for c in range(size):
                if is_node[r, c] and board[r, c] == enemies[k] and dist[r, c] == 1:
                    adjacent_enemy = True
    if adjacent_enemy and _maybe_bomb(board, is_node, dist, me, ammo, blast_strength):
        return BOMB

    # R3: approach an enemy within 3 steps; a repeated direction only with probability 1/2.
    direction = _first_step(_nearest(board, is_node, dist, enemies, 3), me, prev, size)
    if direction >= 0 and (direction != prev_dir[row] or next_uniform(rng, row) < 0.5):
        prev_dir[row] = direction
        return direction

    # R4: grab a power-up within 2 steps.
    direction = _first_step(_nearest(board, is_node, dist, POWER_UPS, 2), me, prev, size)
    if direction >= 0:
        return direction

    # R5: next to wood: bomb it if an escape cell exists, else wait.
    if _first_step(_nearest(board, is_node, dist, WOODS, 1), me, prev, size) >= 0:
        return BOMB if _maybe_bomb(board, is_node, dist, me, ammo, blast_strength) else STOP

    # R6: approach wood within 2 steps unless the next cell is in a bomb's line.
    direction = _first_step(_nearest(board, is_node, dist, WOODS, 2), me, prev, size)
    if direction >= 0:
        nr, nc = mr + ACTION_DR[direction], mc + ACTION_DC[direction]
        if not _in_bomb_line(nr, nc, bomb_cells, bomb_strengths, size):
            return direction

    # R7/R8: wander.
    return _wander(board, is_enemy, me, bomb_cells, bomb_strengths, recent, recent_len, row, rng)


@njit(cache=True)
def _decide_batch(
    board, bomb_blast_strength, position, ammo, blast_strength, agent_id, game_type, active,
    memory_arrays
):
    recent, recent_len, prev_dir, rng = memory_arrays
    actions = np.zeros(board.shape[0], np.int64)
    for m in range(board.shape[0]):
        if not active[m]:
            continue
        actions[m] = decide(
            board[m],
            bomb_blast_strength[m],
            position[m],
            ammo[m],
            blast_strength[m],
            agent_id[m],
            game_type[m],
            recent,
            recent_len,
            prev_dir,
            rng,
            m,
        )
    return actions


@njit(cache=True)
def _draw_seed(state, draw) -> np.uint64:
    """The seed of label draw `draw` (0-based) for a stream now at `state`: splitmix64's output
    for a state offset by the draw, so draws are independent of each other and of the stream."""
    scratch = np.empty(1, np.uint64)
    scratch[0] = state ^ (np.uint64(draw + 1) * np.uint64(0xD1B54A32D192ED03))
    return next_u64(scratch, 0)


@njit(cache=True)
def _count_batch(
    board, bomb_blast_strength, position, ammo, blast_strength, agent_id, game_type, active,
    memory_arrays, draws
):
    recent, recent_len, prev_dir, rng = memory_arrays
    counts = np.zeros((board.shape[0], NUM_ACTIONS), np.uint8)
    one_recent = np.empty((1, RECENT_LENGTH, 2), np.int32)
    one_len = np.empty(1, np.int32)
    one_prev = np.empty(1, np.int32)
    one_rng = np.empty(1, np.uint64)
    for m in range(board.shape[0]):
        if not active[m]:
            continue
        for draw in range(draws):
            one_recent[0] = recent[m]
            one_len[0] = recent_len[m]
            one_prev[0] = prev_dir[m]
            one_rng[0] = _draw_seed(rng[m], draw)
            action = decide(board[m], bomb_blast_strength[m], position[m], ammo[m],
                            blast_strength[m], agent_id[m], game_type[m],
                            one_recent, one_len, one_prev, one_rng, 0)
            counts[m, action] += 1
    return counts


def _kernel_args(obs: Observation, active: np.ndarray | None) -> tuple:
    """The batched kernels' observation arguments, in the dtypes they are compiled for."""
    if active is None:
        active = np.ones(obs.board.shape[0], np.bool_)
    return (
        np.ascontiguousarray(obs.board, np.uint8),
        np.ascontiguousarray(obs.bomb_blast_strength, np.uint8),
        np.ascontiguousarray(obs.position, np.int32),
        np.ascontiguousarray(obs.ammo, np.int32),
        np.ascontiguousarray(obs.blast_strength, np.int32),
        np.ascontiguousarray(obs.agent_id, np.int32),
        np.ascontiguousarray(obs.game_type, np.int32),
        np.ascontiguousarray(active, np.bool_),
    )


def simple_action_counts(
    obs: Observation, memory: SimpleMemory, draws: int, active: np.ndarray | None = None
) -> np.ndarray:
    """How often SimpleAgent picks each action (M, 6) in `draws` decisions per row.

    SimpleAgent breaks ties at random, so an observation and its memory define a distribution
    over actions, of which one recorded action is a single sample. Each draw decides from a copy
    of row m's memory with its own random stream (seeded from the row's stream state and the draw
    index, so the counts are reproducible); `memory` is left untouched. The counts divided by
    `draws` estimate the distribution; rows where `active` is False get zeros.
    """
    if not 0 < draws < 256:
        raise ValueError(f"draws must be in 1..255 (counts are stored as uint8), got {draws}")
    return _count_batch(*_kernel_args(obs, active), tuple(memory), draws)


def simple_actions(
    obs: Observation, memory: SimpleMemory, active: np.ndarray | None = None
) -> np.ndarray:
    """SimpleAgent actions (M,) for a batch of observations with leading shape (M,).

    Row m of `memory` belongs to the agent seeing `obs.select(m)` and is updated in place. Rows
    where `active` is False (dead agents, finished games) are skipped and get Stop, leaving their
    memory and random stream untouched.
    """
    return _decide_batch(*_kernel_args(obs, active), tuple(memory))


class SimpleAgent:
    """The Agent protocol on top of the compiled kernel, with a memory of one row."""

    def __init__(self) -> None:
        self.agent_id = 0
        self.game_type = TEAM_GAME
        self.memory = new_memory(1, np.random.default_rng(0))

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        self.agent_id, self.game_type = agent_id, game_type
        self.memory = new_memory(1, rng)

    def act(self, obs: Observation) -> int:
        """The decision for this seat (from `reset`); scalars go in as int32, like the batched
        rows, so both paths share one compiled version of the kernel."""
        return int(
            decide(
                np.ascontiguousarray(obs.board, np.uint8),
                np.ascontiguousarray(obs.bomb_blast_strength, np.uint8),
                np.ascontiguousarray(obs.position, np.int32),
                np.int32(obs.ammo),
                np.int32(obs.blast_strength),
                np.int32(self.agent_id),
                np.int32(self.game_type),
                *self.memory,
                0,
            )
        )
