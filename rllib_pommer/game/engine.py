"""The two ways to play: `Games` steps N games in one compiled call, `Game` wraps a single one.

Both validate actions in Python (so nothing bad reaches compiled code), then run the same kernels,
and both emit the four agents' observations after every step as `Observation` arrays. In TeamRadio
an action may carry two words (docs/rules.md §10); the words each agent sent are in the state
(`GameState.radio`) and what each agent hears is `message`, beside the observations.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numba import njit

from .constants import (
    NUM_ACTIONS,
    NUM_AGENTS,
    RADIO_NUM_WORDS,
    RADIO_VOCAB_SIZE,
    TEAM_PRESET,
    GameConfig,
    GameType,
    Item,
    Result,
    has_radio,
    teammate_of,
)
from .generator import reset_game
from .observation import Observation, empty_observations
from .observe import observe_game
from .serialize import dump_state, load_state
from .state import A_ALIVE, M_DONE, GameState, empty_state
from .step import step_game

# The seat whose words each agent hears, by agent id.
TEAMMATE_SEATS = [teammate_of(a, GameType.TEAM) - Item.AGENT0 for a in range(NUM_AGENTS)]
RADIO_ACTION_SIZE = 1 + RADIO_NUM_WORDS  # [move, word, word]
# Exclusive bounds of an action's parts, [move, word, word] (a move alone: the first).
_BOUNDS = np.array([NUM_ACTIONS] + [RADIO_VOCAB_SIZE] * RADIO_NUM_WORDS, np.int64)


@njit(cache=True)
def _first_out_of_range(actions, bounds):
    """(game, agent, part) of the first action part outside 0..bound - 1, else (-1, -1, -1);
    `actions` (N, 4) moves or (N, 4, 3) [move, word, word]."""
    for n in range(actions.shape[0]):
        for a in range(NUM_AGENTS):
            if actions.ndim == 3:
                for j in range(RADIO_ACTION_SIZE):
                    if actions[n, a, j] < 0 or actions[n, a, j] >= bounds[j]:
                        return n, a, j
            elif actions[n, a] < 0 or actions[n, a] >= bounds[0]:
                return n, a, 0
    return -1, -1, -1


@njit(cache=True)
def _step_batch(board, agents, bombs, flames, items, meta, radio, actions, rewards, results, burn,
                killers, laid, game_type, max_steps, blast_cap, view_radius, o_board, o_blast,
                o_life, o_dir, o_flame, o_pos, o_ammo, o_strength, o_kick, o_alive, o_type, o_step):
    """Step every game that is not done yet and observe it; done games are left untouched.

    `actions` are (N, 4) moves, or (N, 4, 3) [move, word, word] (numba compiles each form
    apart: the test on `ndim` is decided at compile time). Moves alone send the words (0, 0).
    """
    moves = np.empty(NUM_AGENTS, np.int64)
    words = np.zeros((NUM_AGENTS, RADIO_NUM_WORDS), np.int64)
    for n in range(board.shape[0]):
        if meta[n, M_DONE] != 0:
            continue
        if actions.ndim == 3:
            for a in range(NUM_AGENTS):
                moves[a] = actions[n, a, 0]
                for j in range(RADIO_NUM_WORDS):
                    words[a, j] = actions[n, a, 1 + j]
            game_moves = moves
        else:
            game_moves = actions[n]
        results[n] = step_game(board[n], agents[n], bombs[n], flames[n], items[n], meta[n],
                               radio[n], game_moves, words, rewards[n], game_type, max_steps,
                               blast_cap, burn[n], killers[n], laid[n])
        observe_game(board[n], agents[n], bombs[n], flames[n], meta[n], view_radius, game_type,
                     o_board[n], o_blast[n], o_life[n], o_dir[n], o_flame[n], o_pos[n],
                     o_ammo[n], o_strength[n], o_kick[n], o_alive[n], o_type[n], o_step[n])


@njit(cache=True)
def _observe_batch(board, agents, bombs, flames, meta, game_type, view_radius, o_board, o_blast,
                   o_life, o_dir, o_flame, o_pos, o_ammo, o_strength, o_kick, o_alive, o_type,
                   o_step):
    for n in range(board.shape[0]):
        observe_game(board[n], agents[n], bombs[n], flames[n], meta[n], view_radius, game_type,
                     o_board[n], o_blast[n], o_life[n], o_dir[n], o_flame[n], o_pos[n],
                     o_ammo[n], o_strength[n], o_kick[n], o_alive[n], o_type[n], o_step[n])


def validate_actions(actions, num_games: int, words: bool = False) -> np.ndarray:
    """(N, 4) moves, or with `words` also (N, 4, 3) [move, word, word], as an int64 array; else
    a ValueError naming the game, agent and value (words are 0..7, moves 0..5)."""
    arr = np.asarray(actions)
    shapes = [(num_games, NUM_AGENTS)] + [(num_games, NUM_AGENTS, RADIO_ACTION_SIZE)] * words
    if arr.shape not in shapes:
        what = "moves or [move, word, word]" if words else "actions"
        raise ValueError(f"actions: expected {NUM_AGENTS} {what} per game for {num_games} "
                         f"game(s), shape {' or '.join(map(str, shapes))}, got shape {arr.shape}")
    if arr.dtype != np.int64:
        arr = _integers(arr)
    n, a, part = _first_out_of_range(arr, _BOUNDS)
    if n >= 0:
        value = arr[n, a, part] if arr.ndim == 3 else arr[n, a]
        raise ValueError(f"game {n} agent {a}: {'word' if part else 'action'} {value} out of "
                         f"range 0..{_BOUNDS[part] - 1}")
    return arr


def _integers(arr: np.ndarray) -> np.ndarray:
    """`arr` as int64 if every element is an integer, else a ValueError naming game and agent."""
    if arr.dtype.kind in "iu":
        return arr.astype(np.int64)
    rows = arr.reshape(arr.shape[0] * NUM_AGENTS, -1)
    for i, row in enumerate(rows):
        for j, x in enumerate(row):
            if not _is_integer(x):
                raise ValueError(f"game {i // NUM_AGENTS} agent {i % NUM_AGENTS}: "
                                 f"{'word' if j else 'action'} {x!r} is not an integer")
    return arr.astype(np.int64)


def radio_actions(actions) -> np.ndarray:
    """One game's four actions, each a move or [move, word, word], as a (4, 3) array; a plain
    move sends the words (0, 0), as in the reference. A ValueError names a malformed agent."""
    if isinstance(actions, (str, bytes)) or not isinstance(actions, Sequence | np.ndarray) \
            or len(actions) != NUM_AGENTS:
        raise ValueError(f"actions: expected {NUM_AGENTS} actions, got {actions!r:.80}")
    out = np.zeros((NUM_AGENTS, RADIO_ACTION_SIZE), np.int64)
    for a, action in enumerate(actions):
        if _is_integer(action):
            out[a, 0] = action
        elif (isinstance(action, Sequence | np.ndarray) and len(action) == RADIO_ACTION_SIZE
              and all(_is_integer(x) for x in action)):
            out[a] = action
        else:
            raise ValueError(f"game 0 agent {a}: expected a move or [move, word, word] of "
                             f"integers, got {action!r:.80}")
    return out


def _kernel_outputs(o: Observation) -> tuple:
    """The observation arrays the kernels fill (agent_id is fixed at allocation)."""
    return (o.board, o.bomb_blast_strength, o.bomb_life, o.bomb_moving_direction, o.flame_life,
            o.position, o.ammo, o.blast_strength, o.can_kick, o.alive, o.game_type, o.step_count)


def _is_integer(x) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, (bool, np.bool_))


class Games:
    """N games of one preset, stepped together (the batched API).

    Beside the state the engine keeps who killed whom (`game/kills.py`): `killers` (N, 4), for
    each dead agent the bit mask of the agents whose fire it died in (0 while alive, or when the
    fire predates a loaded state), and `burn` (N, S, S), the same credit for the fire on each
    cell. It also counts the bombs each agent laid in the game, `laid` (N, 4). None of these is
    part of the reference's state, so none is serialized or compared.
    """

    def __init__(self, num_games: int, config: GameConfig = TEAM_PRESET):
        if num_games <= 0:
            raise ValueError(f"num_games must be positive, got {num_games}")
        self.config = config
        self.radio = has_radio(config.game_type)
        self.state: GameState = empty_state(num_games, config.board_size)
        self.obs: Observation = empty_observations(num_games, config.board_size)
        self.rewards = np.zeros((num_games, NUM_AGENTS), np.int64)
        self.results = np.full(num_games, int(Result.INCOMPLETE), np.int64)
        self.burn = np.zeros((num_games, config.board_size, config.board_size), np.uint8)
        self.killers = np.zeros((num_games, NUM_AGENTS), np.uint8)
        self.laid = np.zeros((num_games, NUM_AGENTS), np.int64)

    @property
    def num_games(self) -> int:
        return self.state.num_games

    @property
    def done(self) -> np.ndarray:
        return self.state.meta[:, M_DONE] != 0

    @property
    def alive(self) -> np.ndarray:
        return self.state.agents[:, :, A_ALIVE] != 0

    @property
    def message(self) -> np.ndarray:
        """(N, 4, 2) uint8: the `message` of each agent's current observation, the words its
        teammate sent in the step that produced it (TeamRadio; zero after a reset, and always
        zero in the other games). A copy."""
        return self.state.radio[:, TEAMMATE_SEATS]

    def reset(self, seeds: Sequence[int] | np.ndarray, indices=None) -> Observation:
        """Generate new games (one seed each) into all slots, or into `indices`."""
        indices = range(self.num_games) if indices is None else indices
        if len(seeds) != len(indices):
            raise ValueError(f"reset: {len(seeds)} seeds for {len(indices)} games")
        for index, seed in zip(indices, seeds, strict=True):
            reset_game(self.state, index, np.random.default_rng(seed), self.config)
            self._clear(index)
        return self.observe()

    def load(self, index: int, state: Mapping) -> None:
        """Put a reference state dict into slot `index` (validated; see serialize.load_state)."""
        load_state(state, self.state, index)
        self._clear(index)

    def _clear(self, index: int) -> None:
        self.rewards[index] = 0
        self.results[index] = Result.INCOMPLETE
        self.burn[index] = 0
        self.killers[index] = 0
        self.laid[index] = 0

    def dump(self, index: int) -> dict:
        return dump_state(self.state, index, self.config.game_type)

    def observe(self) -> Observation:
        s, o = self.state, self.obs
        _observe_batch(s.board, s.agents, s.bombs, s.flames, s.meta, int(self.config.game_type),
                       self.config.view_radius, *_kernel_outputs(o))
        return o

    def step(self, actions) -> tuple[Observation, np.ndarray, np.ndarray, np.ndarray]:
        """Apply (N, 4) moves, or in TeamRadio (N, 4, 3) [move, word, word]; return observations,
        rewards (N, 4), done (N,), results (N,).

        Moves alone send the words (0, 0). Games already done are not stepped (their rows keep
        the last values).
        """
        arr = np.asarray(actions)
        if arr.ndim == 3 and not self.radio:
            raise ValueError(f"actions: words are sent in TeamRadio games only; this is a "
                             f"{self.config.name!r} game: pass (N, 4) moves")
        acts = validate_actions(arr, self.num_games, self.radio)
        s, o, c = self.state, self.obs, self.config
        _step_batch(s.board, s.agents, s.bombs, s.flames, s.items, s.meta, s.radio, acts,
                    self.rewards, self.results, self.burn, self.killers, self.laid,
                    int(c.game_type), c.max_steps, c.blast_cap, c.view_radius, *_kernel_outputs(o))
        return o, self.rewards, self.done, self.results


class Game:
    """One game, one Python call per step (the single-game API)."""

    def __init__(self, config: GameConfig = TEAM_PRESET):
        self._games = Games(1, config)
        self.config = config

    @classmethod
    def from_state(cls, state: Mapping, config: GameConfig = TEAM_PRESET) -> Game:
        game = cls(config)
        game.load(state)
        return game

    @property
    def batch(self) -> Games:
        """The underlying batch of one (for tools that work on batches, e.g. recording)."""
        return self._games

    @property
    def state(self) -> GameState:
        return self._games.state

    @property
    def done(self) -> bool:
        return bool(self._games.done[0])

    @property
    def message(self) -> np.ndarray:
        """(4, 2): what each agent hears in its current observation (`Games.message`)."""
        return self._games.message[0]

    def reset(self, seed: int) -> Observation:
        return self._games.reset([seed]).select(0)

    def load(self, state: Mapping) -> Observation:
        self._games.load(0, state)
        return self._games.observe().select(0)

    def dump(self) -> dict:
        return self._games.dump(0)

    def step(self, actions) -> tuple[Observation, np.ndarray, bool, dict]:
        """Apply 4 actions; return the 4 observations, rewards (4,), done and the info dict.

        An action is a move, or in TeamRadio a move or [move, word, word] (the two may mix, as
        in the reference: a move alone sends the words (0, 0)).
        """
        if self.done:
            raise ValueError("step: the game is over; reset or load a new one")
        if isinstance(actions, np.ndarray):
            arr = actions
        else:
            try:
                arr = np.asarray(actions)
            except ValueError:  # moves mixed with [move, word, word]
                arr = radio_actions(actions)
            if arr.dtype == object:
                arr = radio_actions(actions)
        if arr.ndim == 1 or arr.shape == (NUM_AGENTS, RADIO_ACTION_SIZE):
            arr = arr[None]
        obs, rewards, done, results = self._games.step(arr)
        return obs.select(0), rewards[0], bool(done[0]), info_dict(int(results[0]), rewards[0])


def info_dict(result: int, rewards: np.ndarray) -> dict:
    """The reference's info: result code and name, plus winners on a win."""
    info = {"result": result, "result_name": Result(result).name.capitalize()}
    if result == Result.WIN:
        info["winners"] = [i for i in range(NUM_AGENTS) if rewards[i] == 1]
    return info
