"""The two ways to play: `Games` steps N games in one compiled call, `Game` wraps a single one.

Both validate actions in Python (so nothing bad reaches compiled code), then run the same kernels,
and both emit the four agents' observations after every step as `Observation` arrays.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numba import njit

from .constants import NUM_ACTIONS, NUM_AGENTS, TEAM_PRESET, GameConfig, Result
from .generator import reset_game
from .observation import Observation, empty_observations
from .observe import observe_game
from .serialize import dump_state, load_state
from .state import A_ALIVE, M_DONE, GameState, empty_state
from .step import step_game


@njit(cache=True)
def _step_batch(board, agents, bombs, flames, items, meta, actions, rewards, results, burn,
                killers, game_type, max_steps, blast_cap, view_radius, o_board, o_blast, o_life,
                o_dir, o_flame, o_pos, o_ammo, o_strength, o_kick, o_alive, o_type, o_step):
    """Step every game that is not done yet and observe it; done games are left untouched."""
    for n in range(board.shape[0]):
        if meta[n, M_DONE] != 0:
            continue
        results[n] = step_game(board[n], agents[n], bombs[n], flames[n], items[n], meta[n],
                               actions[n], rewards[n], game_type, max_steps, blast_cap,
                               burn[n], killers[n])
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


def validate_actions(actions, num_games: int) -> np.ndarray:
    """Actions as an (N, 4) int64 array, or a ValueError naming the game, agent and value."""
    arr = np.asarray(actions)
    if arr.shape != (num_games, NUM_AGENTS):
        raise ValueError(
            f"actions: expected {NUM_AGENTS} actions per game for {num_games} game(s), "
            f"got shape {arr.shape}"
        )
    if arr.dtype.kind not in "iu":
        bad = np.argwhere([[not _is_integer(x) for x in row] for row in arr.reshape(-1, 4)])
        if len(bad):
            n, a = bad[0]
            raise ValueError(f"game {n} agent {a}: action {arr[n, a]!r} is not an integer")
        arr = arr.astype(np.int64)
    out_of_range = (arr < 0) | (arr >= NUM_ACTIONS)
    if out_of_range.any():
        n, a = np.argwhere(out_of_range)[0]
        raise ValueError(
            f"game {n} agent {a}: action {arr[n, a]} out of range 0..{NUM_ACTIONS - 1}"
        )
    return arr.astype(np.int64, copy=False)


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
    cell. Neither is part of the reference's state, so neither is serialized or compared.
    """

    def __init__(self, num_games: int, config: GameConfig = TEAM_PRESET):
        if num_games <= 0:
            raise ValueError(f"num_games must be positive, got {num_games}")
        self.config = config
        self.state: GameState = empty_state(num_games, config.board_size)
        self.obs: Observation = empty_observations(num_games, config.board_size)
        self.rewards = np.zeros((num_games, NUM_AGENTS), np.int64)
        self.results = np.full(num_games, int(Result.INCOMPLETE), np.int64)
        self.burn = np.zeros((num_games, config.board_size, config.board_size), np.uint8)
        self.killers = np.zeros((num_games, NUM_AGENTS), np.uint8)

    @property
    def num_games(self) -> int:
        return self.state.num_games

    @property
    def done(self) -> np.ndarray:
        return self.state.meta[:, M_DONE] != 0

    @property
    def alive(self) -> np.ndarray:
        return self.state.agents[:, :, A_ALIVE] != 0

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

    def dump(self, index: int) -> dict:
        return dump_state(self.state, index, self.config.game_type)

    def observe(self) -> Observation:
        s, o = self.state, self.obs
        _observe_batch(s.board, s.agents, s.bombs, s.flames, s.meta, int(self.config.game_type),
                       self.config.view_radius, *_kernel_outputs(o))
        return o

    def step(self, actions) -> tuple[Observation, np.ndarray, np.ndarray, np.ndarray]:
        """Apply (N, 4) actions; return observations, rewards (N, 4), done (N,), results (N,).

        Games already done are not stepped (their rows keep the last values).
        """
        acts = validate_actions(actions, self.num_games)
        s, o, c = self.state, self.obs, self.config
        _step_batch(s.board, s.agents, s.bombs, s.flames, s.items, s.meta, acts, self.rewards,
                    self.results, self.burn, self.killers, int(c.game_type), c.max_steps,
                    c.blast_cap, c.view_radius,
                    *_kernel_outputs(o))
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

    def reset(self, seed: int) -> Observation:
        return self._games.reset([seed]).select(0)

    def load(self, state: Mapping) -> Observation:
        self._games.load(0, state)
        return self._games.observe().select(0)

    def dump(self) -> dict:
        return self._games.dump(0)

    def step(self, actions) -> tuple[Observation, np.ndarray, bool, dict]:
        """Apply 4 actions; return the 4 observations, rewards (4,), done and the info dict."""
        if self.done:
            raise ValueError("step: the game is over; reset or load a new one")
        obs, rewards, done, results = self._games.step(np.asarray(actions).reshape(1, -1)
                                                       if np.ndim(actions) == 1 else actions)
        return obs.select(0), rewards[0], bool(done[0]), info_dict(int(results[0]), rewards[0])


def info_dict(result: int, rewards: np.ndarray) -> dict:
    """The reference's info: result code and name, plus winners on a win."""
    info = {"result": result, "result_name": Result(result).name.capitalize()}
    if result == Result.WIN:
        info["winners"] = [i for i in range(NUM_AGENTS) if rewards[i] == 1]
    return info
