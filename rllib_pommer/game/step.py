"""The forward model: one step of one game, compiled, in the reference's exact sub-step order.

Each function mirrors a sub-step of docs/rules.md §3 and says which. The claim
counters and both settle loops reproduce the reference's quirks on purpose (counters that only grow,
agent-bomb crossings that bounce only the bomb, boomerang and diagonal kicks): fidelity is checked
by replaying the recorded reference games (`python -m rllib_pommer.replay verify`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .blast import mark_blast
from .constants import (
    ACTION_DC,
    ACTION_DR,
    BOMB_LIFE_AT_LAYING,
    FLAME_LIFE_AT_CREATION,
    MAX_AMMO,
    NUM_AGENTS,
    RADIO_NUM_WORDS,
    Action,
    Item,
    Result,
    has_teams,
)
from .state import (
    A_ALIVE,
    A_AMMO,
    A_BLAST,
    A_COL,
    A_KICK,
    A_ROW,
    B_BLAST,
    B_COL,
    B_DIR,
    B_LIFE,
    B_OWNER,
    B_ROW,
    F_COL,
    F_LIFE,
    F_ROW,
    I_CODE,
    I_COL,
    I_ROW,
    M_BOMBS,
    M_DONE,
    M_FLAMES,
    M_ITEMS,
    M_STEP,
)

# The kernels' compile-time constants (numba freezes module globals), bound from constants.py.
PASSAGE, RIGID, WOOD, BOMB, FLAMES = (
    int(i) for i in (Item.PASSAGE, Item.RIGID, Item.WOOD, Item.BOMB, Item.FLAMES))
EXTRA_BOMB, INCR_RANGE, KICK = int(Item.EXTRA_BOMB), int(Item.INCR_RANGE), int(Item.KICK)
AGENT0 = int(Item.AGENT0)
STOP, BOMB_ACTION = int(Action.STOP), int(Action.BOMB)
_has_teams = njit(inline="always")(has_teams)
RESULT_WIN, RESULT_TIE, RESULT_INCOMPLETE = (
    int(Result.WIN), int(Result.TIE), int(Result.INCOMPLETE))


@njit(cache=True, inline="always")
def _is_power_up(code):
    return code == EXTRA_BOMB or code == INCR_RANGE or code == KICK


@njit(cache=True, inline="always")
def _is_wall(code):
    return code == RIGID or code == WOOD


@njit(cache=True)
def _send_words(agents, words, radio):
    """§10.2: keep each agent's words of this step; one dead at the start of the step sends (0, 0).

    `words` (4, 2) by agent; in games without radio it is all zero.
    """
    for a in range(NUM_AGENTS):
        alive = agents[a, A_ALIVE] != 0
        for j in range(words.shape[1]):
            radio[a, j] = words[a, j] if alive else 0


@njit(cache=True)
def _age_flames(board, flames, items, meta):
    """§3.1: drop flames of life 0 (revealing a hidden item), tick the rest, redraw them."""
    kept = 0
    for i in range(meta[M_FLAMES]):
        r, c, life = flames[i, F_ROW], flames[i, F_COL], flames[i, F_LIFE]
        if life == 0:
            board[r, c] = PASSAGE
            n_items = meta[M_ITEMS]
            for k in range(n_items):
                if items[k, I_ROW] == r and items[k, I_COL] == c:
                    board[r, c] = items[k, I_CODE]
                    for j in range(k, n_items - 1):
                        items[j] = items[j + 1]
                    meta[M_ITEMS] = n_items - 1
                    break
        else:
            flames[kept, F_ROW] = r
            flames[kept, F_COL] = c
            flames[kept, F_LIFE] = life - 1
            kept += 1
    meta[M_FLAMES] = kept
    for i in range(kept):
        board[flames[i, F_ROW], flames[i, F_COL]] = FLAMES


@njit(cache=True)
def _agent_intents(board, agents, bombs, meta, actions, want, laid):
    """§3.2: clear agents' cells, lay bombs (counted in `laid`), and set each living agent's
    wanted cell."""
    size = board.shape[0]
    for a in range(NUM_AGENTS):
        if agents[a, A_ALIVE] == 0:
            continue
        r, c = agents[a, A_ROW], agents[a, A_COL]
        want[a, 0], want[a, 1] = r, c
        board[r, c] = PASSAGE
        action = actions[a]
        if action == BOMB_ACTION:
            n_bombs = meta[M_BOMBS]
            occupied = False
            for b in range(n_bombs):
                if bombs[b, B_ROW] == r and bombs[b, B_COL] == c:
                    occupied = True
                    break
            if not occupied and agents[a, A_AMMO] > 0:
                agents[a, A_AMMO] -= 1
                bombs[n_bombs, B_ROW] = r
                bombs[n_bombs, B_COL] = c
                bombs[n_bombs, B_OWNER] = a
                bombs[n_bombs, B_LIFE] = BOMB_LIFE_AT_LAYING
                bombs[n_bombs, B_BLAST] = agents[a, A_BLAST]
                bombs[n_bombs, B_DIR] = 0
                meta[M_BOMBS] = n_bombs + 1
                laid[a] += 1
        elif action != STOP:
            tr, tc = r + ACTION_DR[action], c + ACTION_DC[action]
            if 0 <= tr < size and 0 <= tc < size and not _is_wall(board[tr, tc]):
                want[a, 0], want[a, 1] = tr, tc


@njit(cache=True)
def _bomb_intents(board, bombs, n_bombs, bwant):
    """§3.3: clear bombs' cells and set each moving bomb's wanted cell."""
    size = board.shape[0]
    for b in range(n_bombs):
        r, c = bombs[b, B_ROW], bombs[b, B_COL]
        bwant[b, 0], bwant[b, 1] = r, c
        board[r, c] = PASSAGE
        d = bombs[b, B_DIR]
        if d != 0:
            tr, tc = r + ACTION_DR[d], c + ACTION_DC[d]
            if 0 <= tr < size and 0 <= tc < size:
                code = board[tr, tc]
                if not _is_power_up(code) and not _is_wall(code):
                    bwant[b, 0], bwant[b, 1] = tr, tc


@njit(cache=True, inline="always")
def _edge_key(size, r0, c0, r1, c1):
    p = r0 * size + c0
    q = r1 * size + c1
    return min(p, q) * size * size + max(p, q)


@njit(cache=True, inline="always")
def _index_of(keys, n, key):
    for k in range(n):
        if keys[k] == key:
            return k
    return -1


@njit(cache=True)
def _resolve_crossings(size, agents, bombs, n_bombs, want, bwant):
    """§3.4: agents (then bombs) swapping cells along one edge are sent back.

    An agent-bomb crossing sends back only the bomb; the agent then meets the bomb in the kick pass.
    """
    keys = np.empty(NUM_AGENTS + n_bombs, np.int64)
    owners = np.empty(NUM_AGENTS + n_bombs, np.int64)
    is_agent = np.empty(NUM_AGENTS + n_bombs, np.bool_)
    n = 0
    for a in range(NUM_AGENTS):
        if agents[a, A_ALIVE] == 0:
            continue
        r, c = agents[a, A_ROW], agents[a, A_COL]
        if want[a, 0] == r and want[a, 1] == c:
            continue
        key = _edge_key(size, r, c, want[a, 0], want[a, 1])
        found = _index_of(keys, n, key)
        if found >= 0:
            want[a, 0], want[a, 1] = r, c
            other = owners[found]
            want[other, 0], want[other, 1] = agents[other, A_ROW], agents[other, A_COL]
        else:
            keys[n], owners[n], is_agent[n] = key, a, True
            n += 1
    for b in range(n_bombs):
        r, c = bombs[b, B_ROW], bombs[b, B_COL]
        if bwant[b, 0] == r and bwant[b, 1] == c:
            continue
        key = _edge_key(size, r, c, bwant[b, 0], bwant[b, 1])
        found = _index_of(keys, n, key)
        if found >= 0:
            bwant[b, 0], bwant[b, 1] = r, c
            if not is_agent[found]:
                other = owners[found]
                bwant[other, 0], bwant[other, 1] = bombs[other, B_ROW], bombs[other, B_COL]
        else:
            keys[n], owners[n], is_agent[n] = key, b, False
            n += 1


@njit(cache=True, inline="always")
def _agent_moves(agents, want, a):
    return want[a, 0] != agents[a, A_ROW] or want[a, 1] != agents[a, A_COL]


@njit(cache=True, inline="always")
def _bomb_moves(bombs, bwant, b):
    return bwant[b, 0] != bombs[b, B_ROW] or bwant[b, 1] != bombs[b, B_COL]


@njit(cache=True)
def _first_settle(agents, bombs, n_bombs, want, bwant, ao, bo):
    """§3.6: movers into a cell claimed more than once go back, until nothing changes."""
    changed = True
    while changed:
        changed = False
        for a in range(NUM_AGENTS):
            if agents[a, A_ALIVE] == 0 or not _agent_moves(agents, want, a):
                continue
            if ao[want[a, 0], want[a, 1]] > 1 or bo[want[a, 0], want[a, 1]] > 1:
                want[a, 0], want[a, 1] = agents[a, A_ROW], agents[a, A_COL]
                ao[want[a, 0], want[a, 1]] += 1
                changed = True
        for b in range(n_bombs):
            if not _bomb_moves(bombs, bwant, b):
                continue
            if bo[bwant[b, 0], bwant[b, 1]] > 1 or ao[bwant[b, 0], bwant[b, 1]] > 1:
                bwant[b, 0], bwant[b, 1] = bombs[b, B_ROW], bombs[b, B_COL]
                bo[bwant[b, 0], bwant[b, 1]] += 1
                changed = True


@njit(cache=True, inline="always")
def _push(rows, count, x, y, z):
    """Append (x, y, z) to a fixed-capacity table holding `count` rows; return the new count."""
    rows[count, 0], rows[count, 1], rows[count, 2] = x, y, z
    return count + 1


@njit(cache=True)
def _kick_pass(board, agents, bombs, n_bombs, actions, want, bwant, ao, bo, kicker_of, kicked_by):
    """§3.7: an agent meeting a bomb kicks it if it can and the cell beyond is free.

    Resets are deferred to the end of the pass (so two kicks may approve one target; the second
    settle loop undoes both). Returns whether anything was deferred.
    """
    size = board.shape[0]
    defer_bomb = np.empty((n_bombs, 3), np.int64)
    defer_agent = np.empty((n_bombs, 3), np.int64)
    n_defer_bomb = 0
    n_defer_agent = 0
    for b in range(n_bombs):
        dr, dc = bwant[b, 0], bwant[b, 1]
        if ao[dr, dc] == 0:
            continue
        a = -1
        for i in range(NUM_AGENTS):
            if agents[i, A_ALIVE] != 0 and want[i, 0] == dr and want[i, 1] == dc:
                a = i
                break
        if a < 0:
            continue
        bomb_row, bomb_col = bombs[b, B_ROW], bombs[b, B_COL]
        if not _agent_moves(agents, want, a):
            if _bomb_moves(bombs, bwant, b):
                n_defer_bomb = _push(defer_bomb, n_defer_bomb, b, bomb_row, bomb_col)
            continue
        kicked = False
        if agents[a, A_KICK] != 0:
            direction = actions[a]
            tr, tc = dr + ACTION_DR[direction], dc + ACTION_DC[direction]
            if (
                0 <= tr < size
                and 0 <= tc < size
                and ao[tr, tc] == 0
                and bo[tr, tc] == 0
                and not _is_power_up(board[tr, tc])
                and not _is_wall(board[tr, tc])
            ):
                bo[dr, dc] = 0
                n_defer_bomb = _push(defer_bomb, n_defer_bomb, b, tr, tc)
                kicker_of[a] = b
                kicked_by[b] = a
                bombs[b, B_DIR] = direction
                kicked = True
        if not kicked:
            n_defer_bomb = _push(defer_bomb, n_defer_bomb, b, bomb_row, bomb_col)
            n_defer_agent = _push(defer_agent, n_defer_agent, a, agents[a, A_ROW],
                                  agents[a, A_COL])
    for k in range(n_defer_bomb):
        b, r, c = defer_bomb[k, 0], defer_bomb[k, 1], defer_bomb[k, 2]
        bwant[b, 0], bwant[b, 1] = r, c
        bo[r, c] += 1
    for k in range(n_defer_agent):
        a, r, c = defer_agent[k, 0], defer_agent[k, 1], defer_agent[k, 2]
        want[a, 0], want[a, 1] = r, c
        ao[r, c] += 1
    return n_defer_bomb + n_defer_agent > 0


@njit(cache=True)
def _second_settle(agents, bombs, n_bombs, want, bwant, ao, bo, kicker_of, kicked_by):
    """§3.8: stricter loop after kicks; any bomb claim now blocks an agent, any agent a bomb."""
    changed = True
    while changed:
        changed = False
        for a in range(NUM_AGENTS):
            if agents[a, A_ALIVE] == 0 or not _agent_moves(agents, want, a):
                continue
            if ao[want[a, 0], want[a, 1]] > 1 or bo[want[a, 0], want[a, 1]] != 0:
                b = kicker_of[a]
                if b >= 0:
                    bwant[b, 0], bwant[b, 1] = bombs[b, B_ROW], bombs[b, B_COL]
                    bo[bwant[b, 0], bwant[b, 1]] += 1
                    kicked_by[b] = -1
                    kicker_of[a] = -1
                want[a, 0], want[a, 1] = agents[a, A_ROW], agents[a, A_COL]
                ao[want[a, 0], want[a, 1]] += 1
                changed = True
        for b in range(n_bombs):
            if not _bomb_moves(bombs, bwant, b) and kicked_by[b] < 0:
                continue
            if bo[bwant[b, 0], bwant[b, 1]] > 1 or ao[bwant[b, 0], bwant[b, 1]] != 0:
                bwant[b, 0], bwant[b, 1] = bombs[b, B_ROW], bombs[b, B_COL]
                bo[bwant[b, 0], bwant[b, 1]] += 1
                a = kicked_by[b]
                if a >= 0:
                    want[a, 0], want[a, 1] = agents[a, A_ROW], agents[a, A_COL]
                    ao[want[a, 0], want[a, 1]] += 1
                    kicked_by[b] = -1
                    kicker_of[a] = -1
                changed = True


@njit(cache=True)
def _commit_moves(board, agents, bombs, n_bombs, actions, want, bwant, kicked_by, blast_cap):
    """§3.9-3.10: move bombs (a blocked bomb stops for good), then agents, who pick up power-ups."""
    for b in range(n_bombs):
        if not _bomb_moves(bombs, bwant, b) and kicked_by[b] < 0:
            bombs[b, B_DIR] = 0
        else:
            bombs[b, B_ROW], bombs[b, B_COL] = bwant[b, 0], bwant[b, 1]
    for a in range(NUM_AGENTS):
        if agents[a, A_ALIVE] == 0 or not _agent_moves(agents, want, a):
            continue
        r = agents[a, A_ROW] + ACTION_DR[actions[a]]
        c = agents[a, A_COL] + ACTION_DC[actions[a]]
        agents[a, A_ROW], agents[a, A_COL] = r, c
        code = board[r, c]
        if code == EXTRA_BOMB:
            agents[a, A_AMMO] = min(agents[a, A_AMMO] + 1, MAX_AMMO)
        elif code == INCR_RANGE:
            agents[a, A_BLAST] = min(agents[a, A_BLAST] + 1, blast_cap)
        elif code == KICK:
            agents[a, A_KICK] = 1


@njit(cache=True)
def _explode(board, agents, bombs, meta, fire, burn, fresh):
    """§3.11-3.12: tick bombs; detonate (in waves, chains included) into the mask `fire`.

    Kill credit (docs/rules.md §9) rides along without touching the state: each
    detonating bomb burns in the name of its owner and of whoever's fire set it off (lingering
    flames' credit from `burn`, this step's from `fresh`), and ORs those agents' bits into `fresh`
    on every cell of its cross.
    """
    n_bombs = meta[M_BOMBS]
    if n_bombs == 0:
        return
    size = board.shape[0]
    credit = np.empty(n_bombs, np.uint8)
    pending = False
    for b in range(n_bombs):
        credit[b] = 1 << bombs[b, B_OWNER]
        bombs[b, B_LIFE] -= 1
        if bombs[b, B_LIFE] == 0:
            pending = True
        elif board[bombs[b, B_ROW], bombs[b, B_COL]] == FLAMES:
            bombs[b, B_LIFE] = 0
            credit[b] |= burn[bombs[b, B_ROW], bombs[b, B_COL]]
            pending = True
    while pending:
        cross = np.empty((size, size), np.uint8)  # one bomb's blast at a time, for its credit
        pending = False
        kept = 0
        for b in range(n_bombs):
            if bombs[b, B_LIFE] != 0:
                bombs[kept] = bombs[b]
                credit[kept] = credit[b]
                kept += 1
                continue
            owner = bombs[b, B_OWNER]
            agents[owner, A_AMMO] = min(agents[owner, A_AMMO] + 1, MAX_AMMO)
            cross[:] = 0
            mark_blast(board, cross, bombs[b, B_ROW], bombs[b, B_COL], bombs[b, B_BLAST])
            for r in range(size):
                for c in range(size):
                    if cross[r, c] != 0:
                        fire[r, c] = 1
                        fresh[r, c] |= credit[b]
        n_bombs = kept
        for b in range(n_bombs):
            r, c = bombs[b, B_ROW], bombs[b, B_COL]
            if fire[r, c] != 0:
                bombs[b, B_LIFE] = 0
                credit[b] |= fresh[r, c]
                pending = True
    meta[M_BOMBS] = n_bombs


@njit(cache=True)
def _redraw(board, agents, bombs, flames, meta, fire, was_alive, burn, fresh, killers):
    """§3.13: draw bombs, add and draw flames, then agents; an agent on Flames dies.

    A cell set on fire now takes this step's credit in `burn` (older flames keep theirs), and an
    agent that dies here records its cell's credit in `killers`."""
    size = board.shape[0]
    for b in range(meta[M_BOMBS]):
        board[bombs[b, B_ROW], bombs[b, B_COL]] = BOMB
    n_flames = meta[M_FLAMES]
    for r in range(size):
        for c in range(size):
            if fire[r, c] != 0:
                flames[n_flames, F_ROW] = r
                flames[n_flames, F_COL] = c
                flames[n_flames, F_LIFE] = FLAME_LIFE_AT_CREATION
                n_flames += 1
                burn[r, c] = fresh[r, c]
    meta[M_FLAMES] = n_flames
    for i in range(n_flames):
        board[flames[i, F_ROW], flames[i, F_COL]] = FLAMES
    for a in range(NUM_AGENTS):
        if not was_alive[a]:
            continue
        r, c = agents[a, A_ROW], agents[a, A_COL]
        if board[r, c] == FLAMES:
            agents[a, A_ALIVE] = 0
            killers[a] = burn[r, c]
        else:
            board[r, c] = AGENT0 + a


@njit(cache=True)
def _score(agents, meta, game_type, max_steps, rewards):
    """§4: done flag, rewards by agent id and the result code, after the step counter moved."""
    n_alive = 0
    alive_mask = 0
    for a in range(NUM_AGENTS):
        if agents[a, A_ALIVE] != 0:
            n_alive += 1
            alive_mask |= 1 << a
    timeout = meta[M_STEP] >= max_steps
    if _has_teams(game_type):
        team_a_only = alive_mask != 0 and (alive_mask & 0b1010) == 0
        team_b_only = alive_mask != 0 and (alive_mask & 0b0101) == 0
        done = timeout or n_alive <= 1 or team_a_only or team_b_only
        if team_a_only:
            for a in range(NUM_AGENTS):
                rewards[a] = 1 if a % 2 == 0 else -1
        elif team_b_only:
            for a in range(NUM_AGENTS):
                rewards[a] = 1 if a % 2 == 1 else -1
        elif timeout or n_alive == 0:
            rewards[:] = -1
        else:
            rewards[:] = 0
    else:
        done = timeout or n_alive <= 1
        for a in range(NUM_AGENTS):
            if n_alive == 1:
                rewards[a] = 1 if agents[a, A_ALIVE] != 0 else -1
            elif timeout:
                rewards[a] = -1
            else:
                rewards[a] = 0 if agents[a, A_ALIVE] != 0 else -1
    if not done:
        return RESULT_INCOMPLETE
    for a in range(NUM_AGENTS):
        if rewards[a] == 1:
            return RESULT_WIN
    return RESULT_TIE


@njit(cache=True)
def step_buffers(size):
    """Zeroed `words`, `rewards`, `burn`, `killers` and `laid` for `step_game` on a board of
    `size`, for a planner that steps copies of one game in silence and reads none of them."""
    return (np.zeros((NUM_AGENTS, RADIO_NUM_WORDS), np.int64), np.zeros(NUM_AGENTS, np.int64),
            np.zeros((size, size), np.uint8), np.zeros(NUM_AGENTS, np.uint8),
            np.zeros(NUM_AGENTS, np.int64))


@njit(cache=True)
def step_game(board, agents, bombs, flames, items, meta, radio, actions, words, rewards, game_type,
              max_steps, blast_cap, burn, killers, laid):
    """Advance one game by one step in place; fill `rewards` (4,) and return the result code.

    `actions` (4,) are the moves and `words` (4, 2) the words sent with them, which land in
    `radio` (4, 2) before anything moves (§10.2).

    `burn` (S, S) and `killers` (4,) are the kill credit kept beside the state (uint8 bit masks of
    agents, `game/kills.py`): the credit of the fire on each cell, and of the fire each dead agent
    died in. `laid` (4,) counts the bombs each agent lays (a bomb action with ammo left, on a
    cell without a bomb). None of them feeds back into the game. Dead agents' actions are
    ignored. The caller validates actions and never steps a done game.
    """
    size = board.shape[0]
    _send_words(agents, words, radio)
    was_alive = agents[:, A_ALIVE] != 0
    _age_flames(board, flames, items, meta)
    want = np.empty((NUM_AGENTS, 2), np.int64)
    _agent_intents(board, agents, bombs, meta, actions, want, laid)
    n_bombs = meta[M_BOMBS]
    bwant = np.empty((n_bombs, 2), np.int64)
    _bomb_intents(board, bombs, n_bombs, bwant)
    _resolve_crossings(size, agents, bombs, n_bombs, want, bwant)
    ao = np.zeros((size, size), np.int64)
    bo = np.zeros((size, size), np.int64)
    for a in range(NUM_AGENTS):
        if agents[a, A_ALIVE] != 0:
            ao[want[a, 0], want[a, 1]] += 1
    for b in range(n_bombs):
        bo[bwant[b, 0], bwant[b, 1]] += 1
    _first_settle(agents, bombs, n_bombs, want, bwant, ao, bo)
    kicker_of = np.full(NUM_AGENTS, -1, np.int64)
    kicked_by = np.full(n_bombs, -1, np.int64)
    if _kick_pass(board, agents, bombs, n_bombs, actions, want, bwant, ao, bo, kicker_of,
                  kicked_by):
        _second_settle(agents, bombs, n_bombs, want, bwant, ao, bo, kicker_of, kicked_by)
    _commit_moves(board, agents, bombs, n_bombs, actions, want, bwant, kicked_by, blast_cap)
    fire = np.zeros((size, size), np.uint8)
    # this step's fire credit; without bombs no fire starts and nothing reads it
    fresh = np.zeros((size, size), np.uint8) if meta[M_BOMBS] else fire
    _explode(board, agents, bombs, meta, fire, burn, fresh)
    _redraw(board, agents, bombs, flames, meta, fire, was_alive, burn, fresh, killers)
    meta[M_STEP] += 1
    result = _score(agents, meta, game_type, max_steps, rewards)
    meta[M_DONE] = result != RESULT_INCOMPLETE
    return result
