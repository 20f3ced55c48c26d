"""`search`: a tree search over the agent's own moves with pessimistic scenarios, in the manner
of Osogami and Takahashi's real-time tree search (ACML 2019), in our own words and code
(docs/search.md says what it does and what it assumes about the enemies).

Per decision the agent rebuilds the state it believes in from its observation and memory
(`belief.py`), then tries every sequence of its own actions `depth` steps deep on copies of that
state with the compiled step, everybody else standing still (moves onto another agent's cell are
not tried). Each leaf is judged by scenarios played forward `horizon` steps (`survival.py`): a
plain one (the bombs on the board go off), a pessimistic one (every believed enemy also lays a
bomb where it stands, its body in the way nearby) and threat scenarios (one enemy walks to a cell
near the agent within the tree's steps and lays a bomb there). Its score puts surviving first (a
way out of the plain scenario, then of the pessimistic one, then of every threat scenario, then
room to move), then the enemies it kills or leaves without a way out of the plain scenario, its
teammate's way out, then enemies standing in the blast of its new bombs, wood those bombs burn,
power-ups it picks up and how near it comes to the nearest enemy (a path cost where wood counts
extra, so it bombs its way through). An action
is worth its best leaf, a move onto a cell next to another agent the mean of that and Stop's
(both may step there and bounce back); ties are broken by a draw from the agent's own seeded
stream.

The effort (depth, horizon, recall) comes from the policy file (`Effort.from_spec`), never from
a clock, so a seeded game replays exactly. `search_actions` decides for a batch of observation
rows with their memory rows, which the arena's `SearchAgent` (one row) and RLlib's fixed module
(`rl/search_module.py`, many) both call; `search_decisions` also counts the actions further
draws of the tie-break would pick from the same values (the soft labels of expert data,
data/expert.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numba import njit

from ..game.blast import mark_blast
from ..game.constants import (
    ACTION_DC,
    ACTION_DR,
    BOMB_LIFE_AT_LAYING,
    NUM_ACTIONS,
    NUM_AGENTS,
    TEAM_PRESET,
    Action,
    GameType,
    Item,
    has_teams,
)
from ..game.observation import Observation
from ..game.state import (
    A_ALIVE,
    A_AMMO,
    A_BLAST,
    A_COL,
    A_ROW,
    B_BLAST,
    B_COL,
    B_LIFE,
    B_OWNER,
    B_ROW,
    M_BOMBS,
    M_FLAMES,
)
from ..game.step import step_buffers, step_game
from .belief import (
    AGENT_BASE,
    CELLS,
    G_COL,
    G_ROW,
    G_SEEN,
    LAST_ACTION,
    P_SEEN,
    RNG,
    empty_belief,
    rebuild,
    remember,
)
from .belief import new_memory as new_belief_memory
from .rng import next_u64, next_uniform, seed_states
from .survival import _walk_steps, escape_cells, play_scenario

STOP, BOMB = int(Action.STOP), int(Action.BOMB)
RIGID, WOOD, BOMB_CODE, FOG = (int(i) for i in (Item.RIGID, Item.WOOD, Item.BOMB, Item.FOG))
EXTRA_BOMB, KICK, AGENT0 = int(Item.EXTRA_BOMB), int(Item.KICK), int(Item.AGENT0)
TEAM_GAME, BLAST_CAP = int(GameType.TEAM), TEAM_PRESET.blast_cap
_has_teams = njit(inline="always")(has_teams)
UNREACHABLE = 1 << 20

# The score of a leaf (docs/search.md §4): survival dominates everything else by orders of size.
DEAD = -1e9  # the agent dies within the tree; each step it lived first adds STEP_LIVED
STEP_LIVED = 1e6
DOOMED = -1e7  # no way out even if nobody lays another bomb
CORNERED = -5e3  # no way out if every enemy lays a bomb where it stands now
ROOM = 10.0  # per cell it can be on at the horizon of the pessimistic scenario, up to ROOM_CAP
ROOM_CAP = 4
IN_BLAST = -50.0  # its cell burns in the plain scenario's first step; less if later
URGENT = 4  # ... and nothing if it burns this many steps or more after the leaf
KILL = 2e3  # per enemy dead, or without a way out of the plain scenario
TEAMMATE_LOST = -3e3  # the teammate has no way out of the plain scenario
WOOD_BURNT = 30.0  # per wooden cell the agent's new bombs burn that no older bomb does
HIT = 150.0  # per enemy standing in the blast of a bomb the agent laid in the tree
POWER_UP = 60.0  # per power-up picked up
HUNT = 6.0  # per unit of path cost to the nearest enemy
WOOD_COST, BOMB_COST = 4, 2  # path cost of entering a wooden cell, a bomb's cell; others 1
ENEMY_WALK = 2  # steps an enemy may walk in the pessimistic scenario, its body blocking
THREATENED = -1.5e3  # some enemy can walk to a cell near the agent and trap it with a bomb there
THREAT = -1e2  # ... and per such cell
THREAT_REACH = 2  # such cells lie within blast - 1 + depth + THREAT_REACH of the agent's cell
MAX_THREATS = 40  # threat scenarios kept per recording
STALE = 10  # with no enemy to head for: fogged cells seen at most this long after the oldest


@dataclass(frozen=True)
class Effort:
    """How hard the agent searches: its own actions `depth` steps deep (6**depth sequences at
    most), each leaf's scenarios `horizon` steps long (at least a bomb's life, so that bombs laid
    in the tree go off within it), and enemies out of view believed where they were last seen
    for `recall` steps."""

    depth: int = 2
    horizon: int = 10
    recall: int = 5

    BOUNDS: ClassVar[dict] = {"depth": (1, 3), "horizon": (BOMB_LIFE_AT_LAYING, 20),
                              "recall": (0, 800)}

    @classmethod
    def from_params(cls, params, where: str) -> Effort:
        """The effort a policy file's keys ask for; a value out of bounds is a one-line
        ValueError naming `where` (the file), the key and the value."""
        for key, value in params.items():
            low, high = cls.BOUNDS[key]
            if not low <= value <= high:
                raise ValueError(f"policy file {where}: {key} must be in {low}..{high}, "
                                 f"got {value!r}")
        return cls(**params)


@njit(cache=True, inline="always")
def _is_enemy(me, other, game_type):
    return other % 2 != me % 2 if _has_teams(game_type) else other != me


@njit(cache=True)
def hunt_distances(board, targets, n_targets):
    """(S, S) path cost from each cell to the nearest of the target cells (rows of `targets`):
    the cost of a path is that of the cells it enters, 1 each, WOOD_COST for wood, BOMB_COST for
    a bomb; rigid walls cannot be entered. Dijkstra from the targets."""
    size = board.shape[0]
    dist = np.full((size, size), UNREACHABLE, np.int64)
    done = np.zeros((size, size), np.bool_)
    for k in range(n_targets):
        dist[targets[k, 0], targets[k, 1]] = 0
    for _ in range(size * size):
        best, br, bc = UNREACHABLE, -1, -1
        for r in range(size):
            for c in range(size):
                if not done[r, c] and dist[r, c] < best:
                    best, br, bc = dist[r, c], r, c
        if br < 0:
            break
        done[br, bc] = True
        code = board[br, bc]
        enter = WOOD_COST if code == WOOD else BOMB_COST if code == BOMB_CODE else 1
        for k in range(1, 5):
            rr, cc = br + ACTION_DR[k], bc + ACTION_DC[k]
            if 0 <= rr < size and 0 <= cc < size and board[rr, cc] != RIGID:
                dist[rr, cc] = min(dist[rr, cc], best + enter)
    return dist


@njit(cache=True)
def _can_play(board, agents, bombs, meta, me, action):
    """Whether `action` is tried: Stop; a bomb with ammo on a cell without one; a move onto the
    board, not into a wall and not onto another agent (in the tree the others stand still, so
    such a move would bounce and look like Stop, but in the game the other agent may step away
    and the move succeed, docs/search.md §2)."""
    r, c = agents[me, A_ROW], agents[me, A_COL]
    if action == STOP:
        return True
    if action == BOMB:
        if agents[me, A_AMMO] < 1:
            return False
        for b in range(meta[M_BOMBS]):
            if bombs[b, B_ROW] == r and bombs[b, B_COL] == c:
                return False
        return True
    rr, cc = r + ACTION_DR[action], c + ACTION_DC[action]
    size = board.shape[0]
    if not (0 <= rr < size and 0 <= cc < size):
        return False
    code = board[rr, cc]
    return code != RIGID and code != WOOD and code < AGENT0


@njit(cache=True)
def _scenario_key(agents, bombs, flames, meta):
    """A hash of what the scenarios depend on besides the searching agent: bombs, flames and
    which agents live (the others stand still in the tree)."""
    h = np.uint64(1469598103934665603)
    prime = np.uint64(1099511628211)
    for b in range(meta[M_BOMBS]):
        for j in range(bombs.shape[1]):
            h = (h ^ np.uint64(bombs[b, j] + 7)) * prime
    for f in range(meta[M_FLAMES]):
        for j in range(flames.shape[1]):
            h = (h ^ np.uint64(flames[f, j] + 11)) * prime
    for a in range(NUM_AGENTS):
        h = (h ^ np.uint64(agents[a, A_ALIVE] + 13)) * prime
    return h


@njit(cache=True)
def _fresh_blasts(board, agents, bombs, meta, me, depth, game_type):
    """What the bombs `me` laid within the tree (life above 9 - depth) would burn: the wooden
    cells no other bomb's blast reaches, and the cells of living enemies."""
    size = board.shape[0]
    new = np.zeros((size, size), np.uint8)
    old = np.zeros((size, size), np.uint8)
    for b in range(meta[M_BOMBS]):
        fresh = bombs[b, B_OWNER] == me and bombs[b, B_LIFE] > BOMB_LIFE_AT_LAYING - 1 - depth
        mark_blast(board, new if fresh else old, bombs[b, B_ROW], bombs[b, B_COL],
                   bombs[b, B_BLAST])
    count = 0
    for r in range(size):
        for c in range(size):
            if new[r, c] and not old[r, c] and board[r, c] == WOOD:
                count += 1
    hit = 0
    for a in range(NUM_AGENTS):
        if agents[a, A_ALIVE] != 0 and _is_enemy(me, a, game_type) and \
                new[agents[a, A_ROW], agents[a, A_COL]]:
            hit += 1
    return count, hit


@njit(cache=True)
def _record_threats(lb, la, lbo, lf, li, lm, lr, me, game_type, depth, home, fire, blocked):
    """Record the threat scenarios of a leaf (docs/search.md §3): for each believed enemy and
    each free cell it can walk to within `depth` steps (the steps it stood still in the tree)
    that lies near `home` (the agent's cell at the root), that enemy standing there and laying
    a bomb on the first step, everybody else standing still without bombs. Returns how many
    were written into `fire`, `blocked` (K, H, S, S)."""
    size = lb.shape[0]
    near = np.zeros((size, size), np.int64)
    board = lb.copy()
    agents = la.copy()
    bombers = np.zeros(NUM_AGENTS, np.bool_)
    n = 0
    for e in range(NUM_AGENTS):
        if la[e, A_ALIVE] == 0 or not _is_enemy(me, e, game_type):
            continue
        er, ec = la[e, A_ROW], la[e, A_COL]
        reach = la[e, A_BLAST] - 1 + depth + THREAT_REACH
        if abs(er - home[0]) + abs(ec - home[1]) > reach + depth:
            continue
        _walk_steps(lb, er, ec, depth, near)
        bombers[:] = False
        bombers[e] = True
        for r in range(size):
            for c in range(size):
                if near[r, c] > depth or abs(r - home[0]) + abs(c - home[1]) > reach:
                    continue
                if n >= fire.shape[0]:
                    return n
                board[:] = lb
                agents[:] = la
                if board[er, ec] == AGENT0 + e:
                    board[er, ec] = 0
                board[r, c] = AGENT0 + e
                agents[e, A_ROW], agents[e, A_COL] = r, c
                play_scenario(board, agents, lbo, lf, li, lm, lr, me, bombers, 0, 0, fire[n],
                              blocked[n])
                n += 1
    return n


@njit(cache=True)
def _leaf_score(lb, la, lbo, lf, li, lm, lr, root_alive, me, game_type, depth, hunt, home,
                cache_keys, cache_plain_fire, cache_plain_blocked, cache_pess_fire,
                cache_pess_blocked, cache_n_threats, cache_threat_fire, cache_threat_blocked,
                n_cached):
    """The score of one leaf (module docstring); returns (score, cache entries used)."""
    mr, mc = la[me, A_ROW], la[me, A_COL]
    key = _scenario_key(la, lbo, lf, lm)
    slot = -1
    for k in range(n_cached):
        if cache_keys[k] == key:
            slot = k
            break
    if slot < 0:
        slot = n_cached
        n_cached += 1
        cache_keys[slot] = key
        bombers = np.zeros(NUM_AGENTS, np.bool_)
        play_scenario(lb, la, lbo, lf, li, lm, lr, me, bombers, 0, 0, cache_plain_fire[slot],
                      cache_plain_blocked[slot])
        for a in range(NUM_AGENTS):
            bombers[a] = la[a, A_ALIVE] != 0 and _is_enemy(me, a, game_type)
        play_scenario(lb, la, lbo, lf, li, lm, lr, me, bombers, ENEMY_WALK, depth,
                      cache_pess_fire[slot], cache_pess_blocked[slot])
        cache_n_threats[slot] = _record_threats(
            lb, la, lbo, lf, li, lm, lr, me, game_type, depth, home, cache_threat_fire[slot],
            cache_threat_blocked[slot])
    plain_fire, plain_blocked = cache_plain_fire[slot], cache_plain_blocked[slot]
    score = 0.0
    if escape_cells(plain_fire, plain_blocked, mr, mc, 1) == 0:
        score += DOOMED
    for t in range(min(URGENT, plain_fire.shape[0])):
        if plain_fire[t, mr, mc]:
            score += IN_BLAST * (URGENT - t) / URGENT
            break
    room = escape_cells(cache_pess_fire[slot], cache_pess_blocked[slot], mr, mc, ROOM_CAP)
    score += CORNERED if room == 0 else ROOM * room
    threats = 0
    for k in range(cache_n_threats[slot]):
        if escape_cells(cache_threat_fire[slot, k], cache_threat_blocked[slot, k], mr, mc, 1) == 0:
            threats += 1
    if threats > 0:
        score += THREATENED + THREAT * threats
    for a in range(NUM_AGENTS):
        if a == me or not root_alive[a]:
            continue
        lost = la[a, A_ALIVE] == 0 or escape_cells(
            plain_fire, plain_blocked, la[a, A_ROW], la[a, A_COL], 1) == 0
        if lost:
            score += KILL if _is_enemy(me, a, game_type) else TEAMMATE_LOST
    wood, hit = _fresh_blasts(lb, la, lbo, lm, me, depth, game_type)
    score += WOOD_BURNT * wood + HIT * hit - HUNT * min(hunt[mr, mc], 1000)
    return score, n_cached


@njit(cache=True)
def root_values(board, agents, bombs, flames, items, meta, radio, me, game_type, depth, horizon,
                hunt):
    """The value of each of the six actions of `me` in the believed state: the best score of
    the leaves below it (module docstring); -inf for an action that plays as Stop does."""
    size = board.shape[0]
    levels = depth + 1
    lb = np.empty((levels,) + board.shape, board.dtype)
    la = np.empty((levels,) + agents.shape, agents.dtype)
    lbo = np.empty((levels,) + bombs.shape, bombs.dtype)
    lf = np.empty((levels,) + flames.shape, flames.dtype)
    li = np.empty((levels,) + items.shape, items.dtype)
    lm = np.empty((levels,) + meta.shape, meta.dtype)
    lr = np.empty((levels,) + radio.shape, radio.dtype)
    lb[0] = board
    la[0] = agents
    lbo[0] = bombs
    lf[0] = flames
    li[0] = items
    lm[0] = meta
    lr[0] = radio
    gain = np.zeros(levels)
    leaves = NUM_ACTIONS ** depth
    cache_keys = np.empty(leaves, np.uint64)
    plain_fire = np.empty((leaves, horizon, size, size), np.bool_)
    plain_blocked = np.empty((leaves, horizon, size, size), np.bool_)
    pess_fire = np.empty((leaves, horizon, size, size), np.bool_)
    pess_blocked = np.empty((leaves, horizon, size, size), np.bool_)
    n_threats = np.zeros(leaves, np.int64)
    threat_fire = np.empty((leaves, MAX_THREATS, horizon, size, size), np.bool_)
    threat_blocked = np.empty((leaves, MAX_THREATS, horizon, size, size), np.bool_)
    home = np.array([agents[me, A_ROW], agents[me, A_COL]], np.int64)
    n_cached = 0
    root_alive = agents[:, A_ALIVE] != 0
    actions = np.zeros(NUM_AGENTS, np.int64)
    words, rewards, burn, killers, laid = step_buffers(size)
    value = np.full(NUM_ACTIONS, -np.inf)
    chosen = np.full(levels, -1, np.int64)
    level = 0
    while level >= 0:
        chosen[level] += 1
        action = chosen[level]
        if action >= NUM_ACTIONS:
            level -= 1
            continue
        if not _can_play(lb[level], la[level], lbo[level], lm[level], me, action):
            continue
        nxt = level + 1
        lb[nxt] = lb[level]
        la[nxt] = la[level]
        lbo[nxt] = lbo[level]
        lf[nxt] = lf[level]
        li[nxt] = li[level]
        lm[nxt] = lm[level]
        lr[nxt] = lr[level]
        actions[me] = action
        step_game(lb[nxt], la[nxt], lbo[nxt], lf[nxt], li[nxt], lm[nxt], lr[nxt], actions, words,
                  rewards, TEAM_GAME, 1 << 30, BLAST_CAP, burn, killers, laid)
        r, c = la[nxt, me, A_ROW], la[nxt, me, A_COL]
        picked = EXTRA_BOMB <= lb[level, r, c] <= KICK and la[nxt, me, A_ALIVE] != 0
        gain[nxt] = gain[level] + (POWER_UP if picked else 0.0)
        if la[nxt, me, A_ALIVE] == 0:
            score = DEAD + STEP_LIVED * level
        elif nxt < depth:
            level = nxt
            chosen[level] = -1
            continue
        else:
            score, n_cached = _leaf_score(
                lb[nxt], la[nxt], lbo[nxt], lf[nxt], li[nxt], lm[nxt], lr[nxt], root_alive, me,
                game_type, depth, hunt, home, cache_keys, plain_fire, plain_blocked, pess_fire,
                pess_blocked, n_threats, threat_fire, threat_blocked, n_cached)
            score += gain[nxt]
        value[chosen[0]] = max(value[chosen[0]], score)
    for action in range(1, 5):
        if value[action] > value[STOP] and _contested(agents, me, action):
            value[action] = 0.5 * (value[action] + value[STOP])
    return value


@njit(cache=True)
def _contested(agents, me, action):
    """Whether another living agent stands next to the cell `action` moves `me` onto, so that
    it may step there too and both bounce back (docs/search.md §2)."""
    rr = agents[me, A_ROW] + ACTION_DR[action]
    cc = agents[me, A_COL] + ACTION_DC[action]
    for a in range(NUM_AGENTS):
        if a == me or agents[a, A_ALIVE] == 0:
            continue
        if abs(agents[a, A_ROW] - rr) + abs(agents[a, A_COL] - cc) == 1:
            return True
    return False


@njit(cache=True)
def pick(value, rng, row):
    """The best of the six action values, each with a uniform draw below 1 added from stream
    `row` of `rng` (which advances): ties and near-ties (values within 1) go to the draw."""
    best = STOP
    best_value = -np.inf
    for action in range(NUM_ACTIONS):
        noisy = value[action] + next_uniform(rng, row)
        if noisy > best_value:
            best, best_value = action, noisy
    return best


DRAW_GAMMA = np.uint64(0xD1B54A32D192ED03)  # spreads a stream's label draws apart


@njit(cache=True)
def count_draws(value, state, draws, counts):
    """Add to `counts` (6,) the actions `pick` chooses from `value` in `draws` draws of streams
    of their own, seeded from a stream at `state` and the draw's index (splitmix64 of the state
    offset by the draw), so the counts are reproducible and the stream itself is left alone."""
    scratch = np.empty(1, np.uint64)
    for draw in range(draws):
        scratch[0] = state ^ (np.uint64(draw + 1) * DRAW_GAMMA)
        scratch[0] = next_u64(scratch, 0)
        counts[pick(value, scratch, 0)] += 1


@njit(cache=True)
def hunt_targets(board, alive, me, game_type, step, memory, targets):
    """Fill `targets` with the cells to head for and return their number: the living enemies
    in view, and those out of view where they were last seen (or started) unless that cell is in
    view now; with none of those, the fogged cells seen longest ago (never-seen ones first), so
    the agent goes looking."""
    size = board.shape[0]
    n = 0
    for a in range(NUM_AGENTS):
        if not alive[a] or not _is_enemy(me, a, game_type):
            continue
        r = memory[AGENT_BASE + 4 * a + G_ROW]
        c = memory[AGENT_BASE + 4 * a + G_COL]
        if memory[AGENT_BASE + 4 * a + G_SEEN] == step or board[r, c] == FOG:
            targets[n, 0], targets[n, 1] = r, c
            n += 1
    if n > 0:
        return n
    oldest = UNREACHABLE
    for p in range(CELLS):
        if board[p // size, p % size] == FOG:
            oldest = min(oldest, memory[P_SEEN * CELLS + p])
    for p in range(CELLS):
        if board[p // size, p % size] == FOG and memory[P_SEEN * CELLS + p] <= oldest + STALE:
            targets[n, 0], targets[n, 1] = p // size, p % size
            n += 1
    return n


@njit(cache=True)
def _decide_rows(board, blast, life, direction, flame, position, ammo, strength, can_kick, alive,
                 agent_id, game_type, step, active, memory, rng, depth, horizon, recall, belief,
                 draws, counts, values):
    m_rows = board.shape[0]
    out = np.zeros(m_rows, np.int64)
    s_board, s_agents, s_bombs, s_flames, s_items, s_meta, s_radio = belief
    targets = np.empty((CELLS, 2), np.int64)
    for m in range(m_rows):
        if not active[m]:
            continue
        me = agent_id[m]
        remember(board[m], blast[m], life[m], direction[m], flame[m], position[m], me, step[m],
                 memory[m])
        s_bombs[:] = 0
        s_flames[:] = 0
        rebuild(board[m], blast[m], life[m], direction[m], flame[m], position[m], ammo[m],
                strength[m], can_kick[m], alive[m], me, step[m], recall, memory[m], s_board,
                s_agents, s_bombs, s_flames, s_meta)
        n_targets = hunt_targets(board[m], alive[m], me, game_type[m], step[m], memory[m],
                                 targets)
        hunt = hunt_distances(s_board, targets, n_targets)
        value = root_values(s_board, s_agents, s_bombs, s_flames, s_items, s_meta, s_radio, me,
                            game_type[m], depth, horizon, hunt)
        values[m] = value
        if draws > 0:
            count_draws(value, rng[m], draws, counts[m])
        out[m] = pick(value, rng, m)
        memory[m, LAST_ACTION] = out[m]
    return out


def new_memory(rows: int, rng: np.random.Generator) -> np.ndarray:
    """Fresh memory rows (`belief.py`) whose random streams are drawn from `rng`."""
    memory = new_belief_memory(rows)
    memory[:, RNG] = seed_states(rng, rows).view(np.int64)
    return memory


def search_actions(obs: Observation, memory: np.ndarray, effort: Effort,
                   active: np.ndarray | None = None) -> np.ndarray:
    """Actions (M,) for observation rows of leading shape (M,); row m of `memory` (M,
    belief.MEMORY_SIZE) belongs to the agent seeing row m and is updated in place. Rows where
    `active` is False are skipped (Stop, memory untouched)."""
    return search_decisions(obs, memory, effort, active)[0]


def search_decisions(obs: Observation, memory: np.ndarray, effort: Effort,
                     active: np.ndarray | None = None,
                     draws: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """`search_actions`'s actions (M,), and (M, 6) uint8 counts of the actions the agent picks
    from the same values in `draws` further draws of its tie-break (`count_draws`: streams of
    their own, so the actions and the memory are those of `search_actions`); all zero without
    draws or where `active` is False. The counts estimate the agent's action distribution: its
    only randomness is that draw."""
    actions, counts, _ = search_values(obs, memory, effort, active, draws)
    return actions, counts


def search_values(obs: Observation, memory: np.ndarray, effort: Effort,
                  active: np.ndarray | None = None,
                  draws: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`search_decisions`'s actions and counts, and (M, 6) the value of each action at the root
    (`root_values`: -inf for an action that plays as Stop; zero where `active` is False)."""
    if not 0 <= draws < 256:
        raise ValueError(f"draws must be in 0..255 (counts are stored as uint8), got {draws}")
    rows = obs.board.shape[0]
    active = np.ones(rows, np.bool_) if active is None else np.asarray(active, np.bool_)
    counts = np.zeros((rows, NUM_ACTIONS), np.uint8)
    values = np.zeros((rows, NUM_ACTIONS))
    rng = np.ascontiguousarray(memory[:, RNG]).view(np.uint64)
    actions = _decide_rows(
        np.ascontiguousarray(obs.board, np.uint8),
        np.ascontiguousarray(obs.bomb_blast_strength, np.uint8),
        np.ascontiguousarray(obs.bomb_life, np.uint8),
        np.ascontiguousarray(obs.bomb_moving_direction, np.uint8),
        np.ascontiguousarray(obs.flame_life, np.uint8),
        np.ascontiguousarray(obs.position, np.int64),
        np.ascontiguousarray(obs.ammo, np.int64),
        np.ascontiguousarray(obs.blast_strength, np.int64),
        np.ascontiguousarray(obs.can_kick, np.int64),
        np.ascontiguousarray(obs.alive, np.bool_),
        np.ascontiguousarray(obs.agent_id, np.int64),
        np.ascontiguousarray(obs.game_type, np.int64),
        np.ascontiguousarray(obs.step_count, np.int64),
        active, memory, rng, effort.depth, effort.horizon, effort.recall, empty_belief(),
        draws, counts, values)
    memory[:, RNG] = rng.view(np.int64)
    return actions, counts, values


class SearchAgent:
    """The Agent protocol over `search_actions`, with a memory of one row."""

    def __init__(self, effort: Effort | None = None) -> None:
        self.effort = effort or Effort()
        self.memory = new_memory(1, np.random.default_rng(0))

    @classmethod
    def from_spec(cls, spec) -> SearchAgent:
        """The agent a `search` policy file describes (`agents/registry.py`)."""
        return cls(Effort.from_params(spec.params, str(spec.path)))

    def reset(self, agent_id: int, game_type: int, rng: np.random.Generator) -> None:
        self.memory = new_memory(1, rng)

    def act(self, obs: Observation) -> int:
        return int(search_actions(obs.as_row(), self.memory, self.effort)[0])
