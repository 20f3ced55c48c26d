"""The four-agent Team game as an environment: the one definition every face of it shares.

`MultiAgentTeam` speaks RLlib's multi-agent protocol (dicts keyed by seat 0..3, `"__all__"` in
terminateds and truncateds) without inheriting from Ray, so the RLlib env (`rl/env.py`), the
PettingZoo env and the single-agent Gymnasium env (this package) play the same episodes with the
same observations and rewards, and only the RLlib one pays for importing Ray.

An agent that dies gets its last observation and its final reward, then leaves; the game ends for
everyone when the engine says so (a team wiped out, or the step limit, a tie). `reward_mode`
(`game/rewards.py`: "shaped", the paper's; "raw", the engine's; "shaped_credit" and "raw_kills",
which pay only the kills credited to the agent's team; "raw_kills_clock", which also charges the
clock; "raw_kills_room" and "raw_kills_trap", which also pay for cornering or trapping the
enemies) decides the reward at an agent's last step and, for "raw_kills", on the steps its team
kills (and for the clock, cornering and trapping on every step).

The final infos carry `winners` (seats, empty on a tie), `died`, `killers` (every seat's
kill-credit mask, `game/kills.py`) and `laid` (the bombs each seat laid, as the engine counts
them), so callbacks can log the true outcome, who killed whom and who bombed whatever the reward
mode. Each reset also draws, from the env's seeded stream, whether the learner's
action filter and jitter correction are on for the episode (`filters` in every info), so the
episode's filters replay with its seed. `set_stage` changes reward mode and filter probabilities.

What an agent observes is the config's `observation` form (`OBSERVATIONS`): "dict", the default
the training uses, holds "planes" (the paper's 19 float planes the networks read) and "raw" (the
`Observation` packed into one int16 vector by `game/raw_codec.py`, from which scripted modules
and the action filter rebuild the exact arrays the compiled agents take), so any policy can sit in
any seat; "planes" is the 19 planes alone, as a Box; "planes_last" the same planes channels-last
(11, 11, 19), the layout RLlib's default CNN encoder reads.

With `memory` every seat keeps a memory row of its own observations (`agents/belief.py`),
fresh at each reset, and its planes are 22: the 19, then the three memory planes of
`imitation/recall.py` (what it saw under today's fog), for a policy with memory; a 19-plane
network reads the first 19 (`network.PommerNet.first_planes`).

`game` picks the variant (`game.constants.TEAM_GAMES`): "team", the default, or "radio",
TeamRadio (docs/rules.md §10), the same game in which every agent also sends its teammate two
words 0..7 each step. There an action is `MultiDiscrete([6, 8, 8])`, [move, word, word] (a plain
move is accepted too and sends (0, 0), as in the reference), and every observation is a Dict
holding also "message": the words the teammate sent in the step that produced it, one-hot (2, 8)
(`features.message_features`); the "planes" and "planes_last" forms become {"planes",
"message"}.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import gymnasium as gym
import numpy as np

from ..agents.belief import new_memory
from ..agents.survival import rooms_under_threat
from ..game.constants import (
    BOARD_SIZE,
    NUM_ACTIONS,
    NUM_AGENTS,
    RADIO_NUM_WORDS,
    RADIO_VOCAB_SIZE,
    TEAM_GAMES,
    TEAM_PRESET,
    has_radio,
)
from ..game.engine import RADIO_ACTION_SIZE, Game
from ..game.observation import Observation
from ..game.raw_codec import RAW_SIZE, pack_raw
from ..game.rewards import (
    CORNERING_WEIGHTS,
    ROOM_CAP,
    ROOM_HORIZON,
    check_reward_mode,
    clock_reward,
    cornering_reward,
    final_reward,
    kill_reward,
)
from ..imitation.features import NUM_PLANES, message_features
from ..imitation.recall import MEMORY_PLANES, input_planes
from ..viz.frames import state_frame
from ..viz.render import draw_frame

RENDER_MODES = ["rgb_array"]  # of the PettingZoo and Gymnasium envs: `MultiAgentTeam.draw`

def planes_space(planes: int = NUM_PLANES) -> gym.spaces.Box:
    """One agent's `planes` float planes (19, or 22 with memory) as a Box."""
    return gym.spaces.Box(0.0, 1.0, (planes, BOARD_SIZE, BOARD_SIZE), np.float32)


def dict_space(planes: int = NUM_PLANES) -> gym.spaces.Dict:
    """The "dict" form's space: the planes and the raw observation."""
    return gym.spaces.Dict({
        "planes": planes_space(planes),
        "raw": gym.spaces.Box(0, np.iinfo(np.int16).max, (RAW_SIZE,), np.int16),
    })


PLANES_SPACE = planes_space()
OBSERVATION_SPACE = dict_space()
ACTION_SPACE = gym.spaces.Discrete(NUM_ACTIONS)
# TeamRadio: [move, word, word], and the teammate's words heard, one-hot.
RADIO_ACTION_SPACE = gym.spaces.MultiDiscrete([NUM_ACTIONS] + [RADIO_VOCAB_SIZE] * RADIO_NUM_WORDS)
MESSAGE_SPACE = gym.spaces.Box(0.0, 1.0, (RADIO_NUM_WORDS, RADIO_VOCAB_SIZE), np.float32)


def _dict_rows(planes: np.ndarray, obs: Observation) -> list[dict[str, np.ndarray]]:
    raw = pack_raw(obs)
    return [{"planes": planes[a], "raw": raw[a]} for a in range(NUM_AGENTS)]


# Observation form -> (one agent's space for a number of planes, the four agents' rows from
# their (4, planes, 11, 11) planes and the engine's (4,) observation rows).
OBSERVATIONS: dict[str, tuple[Callable[[int], gym.Space],
                              Callable[[np.ndarray, Observation], list]]] = {
    "dict": (dict_space, _dict_rows),
    "planes": (planes_space, lambda planes, obs: list(planes)),
    "planes_last": (lambda n: gym.spaces.Box(0.0, 1.0, (BOARD_SIZE, BOARD_SIZE, n), np.float32),
                    lambda planes, obs: list(np.moveaxis(planes, -3, -1))),
}


# The config keys `MultiAgentTeam` reads: the PettingZoo env refuses others (a typo would pass).
CONFIG_KEYS = ("seed", "max_steps", "reward", "observation", "action_filter", "jitter", "game",
               "memory")


def radio_space(space: gym.Space) -> gym.spaces.Dict:
    """An observation form's space in TeamRadio: a Dict's with "message", a Box as "planes"."""
    spaces = dict(space.spaces) if isinstance(space, gym.spaces.Dict) else {"planes": space}
    return gym.spaces.Dict({**spaces, "message": MESSAGE_SPACE})


def check_game(game) -> str:
    """`game` if it names one of `TEAM_GAMES`, else a ValueError naming it."""
    if game not in TEAM_GAMES:
        raise ValueError(f"env config: game {game!r} is not one of {list(TEAM_GAMES)}")
    return game


def _is_radio_action(action) -> bool:
    if isinstance(action, (str, bytes)) or not isinstance(action, (list, tuple, np.ndarray)):
        return False
    arr = np.asarray(action)
    return arr.dtype.kind in "iu" and RADIO_ACTION_SPACE.contains(arr.astype(np.int64))


def check_action(action, agent, radio: bool = False) -> int | np.ndarray:
    """`action` as an int if `ACTION_SPACE` contains it (with `radio`, a move alone), or with
    `radio` as an int64 [move, word, word] if `RADIO_ACTION_SPACE` contains it, else a
    ValueError naming `agent` and the value: 2.7, "5", None or a one-element array are not
    actions (an int64 cast would play 2, 5 or raise a numpy error)."""
    if ACTION_SPACE.contains(action):
        return int(action)
    if radio and _is_radio_action(action):
        return np.asarray(action, np.int64)
    space, what = ((RADIO_ACTION_SPACE, f"[move 0..{NUM_ACTIONS - 1}, word 0..7, word 0..7] or "
                                        f"a move") if radio
                   else (ACTION_SPACE, f"an integer 0..{NUM_ACTIONS - 1}"))
    raise ValueError(f"action of agent {agent!r}: {action!r} is not in {space} ({what})")


def check_max_steps(value) -> int:
    """`value` if it is a whole number of steps >= 1, else a ValueError naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"max_steps must be an integer >= 1, got {value!r}")
    return int(value)


def check_render_mode(render_mode: str | None) -> str | None:
    """`render_mode` if the PettingZoo and Gymnasium envs can draw it, else a ValueError."""
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(f"render_mode {render_mode!r} is not one of {[None, *RENDER_MODES]}")
    return render_mode


def agent_observations(obs: Observation, form: str = "dict",
                       message: np.ndarray | None = None,
                       memory: np.ndarray | None = None) -> dict[int, object]:
    """The four agents' observations in `form` from the engine's (4,) observation rows; with
    the (4, 2) words each agent hears (`Game.message`), TeamRadio's; with the seats' memory
    rows (4, belief.MEMORY_SIZE), which fold these observations in, the memory planes after the
    19 (module docstring)."""
    rows = OBSERVATIONS[form][1](input_planes(obs, memory), obs)
    if message is None:
        return dict(enumerate(rows))
    heard = message_features(message)
    return {a: {**(row if isinstance(row, dict) else {"planes": row}), "message": heard[a]}
            for a, row in enumerate(rows)}


class MultiAgentTeam:
    """The Team game with RLlib's multi-agent API and no Ray (module docstring).

    config: seed, max_steps (default the preset's), reward ("shaped"|"raw"), observation
    ("dict"|"planes"|"planes_last"), action_filter and jitter (per-episode activation
    probabilities of the learner's filters), game ("team"|"radio"), memory (bool: the memory
    planes after the 19, module docstring). Other keys are ignored:
    subclasses read their own (the bench's zero-cost env reads episode_length).
    """

    def __init__(self, config: dict | None = None):
        super().__init__()  # rl/env.PommeEnv puts RLlib's MultiAgentEnv next in line
        config = dict(config or {})
        max_steps = check_max_steps(config.get("max_steps", TEAM_PRESET.max_steps))
        self.game = Game(replace(TEAM_GAMES[check_game(config.get("game", "team"))],
                                 max_steps=max_steps))
        self.radio = has_radio(self.game.config.game_type)
        self.observation_form = config.get("observation", "dict")
        if self.observation_form not in OBSERVATIONS:
            raise ValueError(f"env config: observation {self.observation_form!r} is not one of "
                             f"{list(OBSERVATIONS)}")
        self.memory = new_memory(NUM_AGENTS) if config.get("memory", False) else None
        space = OBSERVATIONS[self.observation_form][0](
            NUM_PLANES if self.memory is None else MEMORY_PLANES)
        self.possible_agents = list(range(NUM_AGENTS))
        self.agents = []
        self.observation_spaces = dict.fromkeys(self.possible_agents,
                                                radio_space(space) if self.radio else space)
        self.agent_action_space = RADIO_ACTION_SPACE if self.radio else ACTION_SPACE
        self.action_spaces = dict.fromkeys(self.possible_agents, self.agent_action_space)
        self._rng = np.random.default_rng(config.get("seed"))
        self.set_stage(config.get("reward", "shaped"), config.get("action_filter", 0.0),
                       config.get("jitter", 0.0))
        self._filters: dict[str, bool] = {}
        self.last_observation: Observation | None = None
        self._cornered: tuple | None = None  # `_cornering()` after the last step

    def set_stage(self, reward: str, action_filter: float, jitter: float) -> None:
        self.reward_mode = check_reward_mode(reward)
        self.filter_probabilities = {"action_filter": float(action_filter),
                                     "jitter": float(jitter)}

    def reset(self, *, seed=None, options=None):
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        self.last_observation = self.game.reset(int(self._rng.integers(2**31)))
        self._cornered = None
        if self.memory is not None:
            self.memory[:] = 0  # a fresh memory for each seat's new game
        self._filters = {name: bool(self._rng.random() < p)
                         for name, p in self.filter_probabilities.items()}
        self.agents = list(self.possible_agents)
        observations = self._observations(self.last_observation)
        return observations, {a: {"filters": self._filters} for a in self.agents}

    def _observations(self, obs: Observation) -> dict[int, object]:
        return agent_observations(obs, self.observation_form,
                                  self.game.message if self.radio else None, self.memory)

    def step(self, action_dict):
        """One step of every agent: `action_dict` maps seats to actions; a seat left out (a
        dead agent) plays Stop (and in TeamRadio sends (0, 0)), as in the engine. An action the
        space refuses is a ValueError before anything moves."""
        actions = np.zeros((NUM_AGENTS, RADIO_ACTION_SIZE) if self.radio else NUM_AGENTS,
                           np.int64)
        for agent, action in action_dict.items():
            if agent not in self.possible_agents:
                raise ValueError(f"unknown agent {agent!r}; agents: {self.possible_agents}")
            if self.radio:  # a move alone sends (0, 0)
                actions[agent, :np.size(action)] = check_action(action, agent, radio=True)
            else:
                actions[agent] = check_action(action, agent)
        cornered_before = None
        if self.reward_mode in CORNERING_WEIGHTS:  # the last step's "after", unless reset since
            cornered_before = self._cornered if self._cornered is not None else self._cornering()
        obs, engine_rewards, done, info = self.game.step(actions)
        self.last_observation = obs
        cornered_after = self._cornered = \
            self._cornering() if cornered_before is not None else None
        alive = self.game.batch.alive[0]
        killers = self.game.batch.killers[0].tolist()
        step, max_steps = int(obs.step_count.max()), self.game.config.max_steps
        winners = info.get("winners", []) if done else []
        all_obs = self._observations(obs)
        acting, self.agents = self.agents, []
        newly_dead = [agent for agent in acting if not alive[agent]]
        observations, rewards, terminateds, infos = {}, {}, {}, {}
        for agent in acting:
            observations[agent] = all_obs[agent]
            infos[agent] = {"filters": self._filters}
            leaves = done or not alive[agent]
            terminateds[agent] = leaves
            rewards[agent] = kill_reward(self.reward_mode, agent, newly_dead, killers) + (
                final_reward(self.reward_mode, agent, done, info, engine_rewards[agent], alive,
                             killers) if leaves else 0.0) + clock_reward(
                self.reward_mode, step, max_steps, leaves, agent in winners)
            if cornered_before is not None:
                rewards[agent] += cornering_reward(self.reward_mode, agent, cornered_before,
                                                   cornered_after, leaves)
            if done:
                infos[agent].update(winners=info.get("winners", []), killers=killers,
                                    died=(~alive).tolist(),
                                    laid=self.game.batch.laid[0].tolist())
            if not leaves:
                self.agents.append(agent)
        terminateds["__all__"] = done
        return observations, rewards, terminateds, {"__all__": False}, infos

    def _cornering(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rooms, trapped, alive) of every seat now, what "raw_kills_room" and
        "raw_kills_trap" pay on (game/rewards.py)."""
        now = [array[0] for array in self.game.batch.state]
        rooms = rooms_under_threat(*now, ROOM_HORIZON, ROOM_CAP)
        trapped = rooms_under_threat(*now, ROOM_HORIZON, 1, False) == 0
        return rooms, trapped, self.game.batch.alive[0].copy()

    def draw(self) -> np.ndarray:
        """The whole board now, uint8 RGB (H, W, 3), drawn by the replay renderer."""
        return np.asarray(draw_frame(state_frame(self.game.dump()), self.game.config.max_steps))
