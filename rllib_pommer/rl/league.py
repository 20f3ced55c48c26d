"""Self-play: frozen snapshots of the learner that join its league of opponents.

A curriculum's `[league]` table declares `slots` frozen modules, `snapshot_0` ... `snapshot_{n-1}`
(`SnapshotModule`: pi only, never trained), built with the algorithm like every other module. A
gate fills them: in stages marked `self_play = true`, the learner's games against the league
(its scripted opponents plus every filled snapshot) are counted in blocks of `gate_games`; a block
won at a rate of at least `gate_win` copies the learner's pi into the next slot (the first empty
one, else the oldest), which from then on plays in the league. Fixed slots, not RLlib's
`Algorithm.add_module` (which RLlib's `self_play` example uses): the set of modules never changes,
so every checkpoint restores into the algorithm the config builds, with no module to re-add
before loading (a restore trap users of `add_module` met), and the weight sync needs no new module
id.

The league's whole state lives in the slots themselves, as buffers beside pi: `born`, the lifetime
episode count at which the slot was filled (-1: empty), and `tally`, the wins and games of the
gate's current block toward filling that slot. RLlib checkpoints every module's state, so the
league's members, their weights and the gate survive `--resume`, `--pack` and a move to another
clone without any file of its own; the callback keeps no state and reads the book from the
learner's modules whenever it needs it.

Prioritized matchmaking (curriculum/matchmaking.py) keeps its book the same way:
`MatchmakingModule`, a module that never plays, holds the learner's decayed wins, losses and ties
against every league member (`Curriculum.league_members`); it exists only in a curriculum that asks
for prioritized matchmaking or an exploiter, so runs started before it restore unchanged. A slot
filled with a new snapshot starts a new record.

An exploiter (AlphaStar's main exploiter) is a second trained module, `exploiter`, built like the
learner from the same weights, that plays the learner and no one else: it is a member of the
learner's league, and so the learner's games against it train both. Its wins against the
learner are counted in blocks (the book's `exploiter` tally); a block of `exploiter_gate_games`
won at `exploiter_gate_win` or more copies its pi into the next snapshot slot, where it stays in
the learner's league as a frozen member, and the exploiter starts again from the learner's pi
and vf as they are then, with fresh optimizer moments, to look for the next weakness.

`LeagueCallback` runs the league after each iteration: the learner's league games (rl/outcomes.py
counts them per member, summed over the iteration) go into the gate, which may fill the next slot
from the learner's pi; the new member's weights go to every env runner, and the stage's callback
(rl/stages.py) maps it at once. Under prioritized matchmaking the games go into the book first, the
league's weights follow from it (curriculum/matchmaking.py) and reach every env runner's mapping in
place. The result's `league` entry says how many snapshots play and where the gate's block stands
(with an `exploiter` entry: its block and the slot it filled), and its `matchmaking` entry gives
each member's share of the coming games, estimated win rate and decayed games.

With learner actors (`train --num-learners N`) every learner holds the whole league: its modules
are the learner's own, and the learners keep identical weights (rl/learner.py). So each step of
the book (the gate's count, a slot filled from pi, the exploiter's block and restart, the
matchmaking records) runs on every learner alike, through RLlib's `foreach_learner`, and every
learner must come to the same answer (`on_every_learner` refuses learners that disagree); a
filled slot and a restarted exploiter are then copied from the first learner to the others with
`LearnerGroup.get_state`/`set_state`, so that they hold the very same weights whatever the
learners' arithmetic did. Reads go to the first learner, as RLlib's checkpoints do.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from ray.rllib.callbacks.callbacks import RLlibCallback
from ray.rllib.core import COMPONENT_LEARNER, COMPONENT_RL_MODULE
from ray.rllib.core.columns import Columns
from ray.rllib.core.rl_module.rl_module import RLModule, RLModuleSpec
from ray.rllib.core.rl_module.torch import TorchRLModule
from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS, NUM_EPISODES, NUM_EPISODES_LIFETIME

from ..curriculum.curriculum import load_curriculum
from ..curriculum.matchmaking import Record, priority
from ..curriculum.names import EXPLOITER, LEARNER
from ..curriculum.settings import LeagueSettings
from ..imitation.network import PommerNet

MATCHMAKING_MODULE = "matchmaking"


@dataclass(frozen=True)
class Slot:
    """One slot's entry in the league's book."""
    module_id: str
    born: int  # lifetime episodes when filled; -1 while empty
    wins: int  # the gate's block toward filling this slot
    games: int

    @property
    def filled(self) -> bool:
        return self.born >= 0


class SnapshotModule(TorchRLModule):
    """A frozen copy of the learner's pi, plus the league's book for its slot (module
    docstring). It samples from pi's logits, as the learner does in training."""

    def setup(self):
        planes = self.observation_space["planes"].shape[0]  # the learner's: 19, or 22 with memory
        self.pi = PommerNet(6, planes=planes).to(memory_format=torch.channels_last)
        self.pi.requires_grad_(False)
        self.register_buffer("born", torch.tensor(-1, dtype=torch.int64))
        self.register_buffer("tally", torch.zeros(2, dtype=torch.int64))

    def _forward(self, batch, **kwargs):
        planes = batch[Columns.OBS]["planes"].contiguous(memory_format=torch.channels_last)
        return {Columns.ACTION_DIST_INPUTS: self.pi(planes)}

    def slot(self, module_id: str) -> Slot:
        return Slot(module_id, int(self.born), int(self.tally[0]), int(self.tally[1]))

    def count(self, wins: int, games: int) -> None:
        self.tally += torch.tensor([wins, games], dtype=torch.int64, device=self.tally.device)

    def fill(self, pi: torch.nn.Module, episodes: int) -> None:
        """Copy `pi`'s weights in and open the slot at `episodes`; its block starts again."""
        self.pi.load_state_dict(pi.state_dict())
        self.born.fill_(episodes)
        self.tally.zero_()


class MatchmakingModule(RLModule):
    """The matchmaking book (module docstring): `results[i]` holds the learner's decayed wins,
    losses and ties against member i of `model_config["members"]`, and `exploiter` the
    exploiter's block (wins, games against the learner). It plays no seat and has no parameters
    (a plain RLModule, as the scripted ones: the learner builds it no optimizer); its state is
    the arrays."""

    def setup(self):
        self.members = list(self.model_config["members"])
        self.results = np.zeros((len(self.members), 3), np.float64)
        self.exploiter = np.zeros(2, np.int64)

    def _forward(self, batch, **kwargs):
        raise RuntimeError("the matchmaking book plays no seat")

    def get_state(self, *args, **kwargs) -> dict:
        return {"results": self.results.copy(), "exploiter": self.exploiter.copy()}

    def set_state(self, state: dict) -> None:
        self.results = np.array(state["results"], np.float64)
        self.exploiter = np.array(state.get("exploiter", (0, 0)), np.int64)

    def records(self) -> dict[str, Record]:
        return {name: Record(*(float(n) for n in row))
                for name, row in zip(self.members, self.results, strict=True)}

    def add(self, results: dict[str, tuple[int, int, int]], halflife: float) -> None:
        """Count each member's new (wins, losses, ties) into its record."""
        records = self.records()
        for name, (wins, losses, ties) in results.items():
            record = records[name].add(wins, losses, ties, halflife)
            self.results[self.members.index(name)] = (record.wins, record.losses, record.ties)

    def forget(self, name: str) -> None:
        self.results[self.members.index(name)] = 0.0


def snapshot_specs(settings: LeagueSettings, members: list[str]) -> dict[str, RLModuleSpec]:
    """The slots' modules, and the matchmaking book's under prioritized matchmaking or with an
    exploiter."""
    specs = {slot: RLModuleSpec(module_class=SnapshotModule) for slot in settings.slot_ids()}
    if settings.prioritized or settings.exploiter:
        specs[MATCHMAKING_MODULE] = RLModuleSpec(module_class=MatchmakingModule,
                                                 model_config={"members": list(members)})
    return specs


def module_of(learner, module_id: str):
    """The learner's module `module_id` itself, never a wrapper around it (RLlib wraps modules
    in DDP with several learners; rl/learner.py does not, this holds either way)."""
    return learner.module[module_id].unwrapped()


def read_book(learner, settings: LeagueSettings) -> list[Slot]:
    """The slots as the learner's modules hold them (run on a learner)."""
    return [module_of(learner, slot).slot(slot) for slot in settings.slot_ids()]


def next_slot(book: list[Slot]) -> Slot:
    """The slot the gate fills next: the first empty one, else the one filled longest ago."""
    empty = [slot for slot in book if not slot.filled]
    return empty[0] if empty else min(book, key=lambda slot: slot.born)


def members(book: list[Slot]) -> tuple[str, ...]:
    """The filled slots, in slot order (the league's snapshot members)."""
    return tuple(slot.module_id for slot in book if slot.filled)


def gate_step(learner, settings: LeagueSettings, wins: int, games: int,
              episodes: int) -> str | None:
    """Count `wins` of `games` league games into the next slot's block (run on a learner);
    when the block is complete, fill that slot from the learner's pi if the block's win rate
    passes the gate, else start a new block. Returns the filled slot's id, or None."""
    if games <= 0:
        return None
    slot = next_slot(read_book(learner, settings))
    module = module_of(learner, slot.module_id)
    module.count(wins, games)
    slot = module.slot(slot.module_id)
    if slot.games < settings.gate_games:
        return None
    if slot.wins / slot.games >= settings.gate_win:
        module.fill(module_of(learner, LEARNER).pi, episodes)
        return slot.module_id
    module.tally.zero_()
    return None


def exploiter_step(learner, settings: LeagueSettings, wins: int, games: int,
                   episodes: int) -> str | None:
    """Count the exploiter's `wins` of `games` against the learner into its block (run on a
    learner); when the block is complete and won at `exploiter_gate_win` or more, copy the
    exploiter's pi into the next snapshot slot and start the exploiter again from the learner
    (module docstring). Returns the filled slot's id, or None."""
    book = module_of(learner, MATCHMAKING_MODULE)
    book.exploiter += np.array([wins, games], np.int64)
    won, played = (int(n) for n in book.exploiter)
    if played < settings.exploiter_gate_games:
        return None
    book.exploiter[:] = 0
    if won / played < settings.exploiter_gate_win:
        return None
    slot = next_slot(read_book(learner, settings)).module_id
    exploiter, main = module_of(learner, EXPLOITER), module_of(learner, LEARNER)
    module_of(learner, slot).fill(exploiter.pi, episodes)
    exploiter.pi.load_state_dict(main.pi.state_dict())
    exploiter.vf.load_state_dict(main.vf.state_dict())
    learner.get_optimizer(EXPLOITER).state.clear()  # Adam's moments belong to the old weights
    return slot


def describe(book: list[Slot], settings: LeagueSettings) -> str:
    """One line for the progress output: members and the gate's block."""
    slot = next_slot(book)
    rate = slot.wins / slot.games if slot.games else float("nan")
    return (f"league {len(members(book))}/{settings.slots} snapshots, gate {slot.games}/"
            f"{settings.gate_games} games at {rate:.2f} (needs {settings.gate_win:.2f})")


def count(runners: dict, key: str) -> int:
    """A counter from the env runners' results; 0 when absent or NaN (an iteration in which no
    episode ended, e.g. the first one after a restore, reports NaN)."""
    value = runners.get(key, 0)
    return 0 if value != value else int(value)


def on_learner(algorithm, func):
    """`func(learner)`'s value on the first learner, which holds the module states that
    checkpoints save; `func` reads only."""
    return next(iter(algorithm.learner_group.foreach_learner(func))).get()


def on_every_learner(algorithm, func):
    """`func(learner)` run on every learner, a step of the league's book; its value, which
    must be the same on all (module docstring)."""
    values = [result.get() for result in algorithm.learner_group.foreach_learner(func)]
    if any(value != values[0] for value in values[1:]):
        raise RuntimeError(f"the learners' league books disagree: {values}; they must hold "
                           f"the same weights and counts (rl/learner.py)")
    return values[0]


def module_states(algorithm, module_ids) -> dict:
    """The first learner's states of modules `module_ids`, through RLlib's
    `LearnerGroup.get_state`."""
    components = [f"{COMPONENT_LEARNER}/{COMPONENT_RL_MODULE}/{mid}" for mid in module_ids]
    state = algorithm.learner_group.get_state(components=components)
    return state[COMPONENT_LEARNER][COMPONENT_RL_MODULE]


def share_modules(algorithm, module_ids) -> None:
    """Modules `module_ids` of the first learner copied onto every other learner (module
    docstring), through RLlib's `LearnerGroup.set_state`, and onto every env runner
    (`push_modules`), from one read of their states. The state carries no weights sequence
    number, which would make a learner at the same number skip it."""
    if not module_ids:
        return
    states = module_states(algorithm, module_ids)
    group = algorithm.learner_group
    if not group.is_local and len(group) > 1:
        group.set_state({COMPONENT_LEARNER: {COMPONENT_RL_MODULE: states}})
    push_modules(algorithm, module_ids, states)


def push_modules(algorithm, slots, states: dict | None = None) -> None:
    """The learner's copies of modules `slots` (snapshots, a restarted exploiter), or their
    `states` where the caller has read them, onto every env runner. Not RLlib's weight sync,
    which an env runner skips when the learner's weights sequence number has not moved since
    the last sync (a slot filled after an update has the same number), and which ran before the
    callback changed them."""
    if not slots:
        return
    states = states or module_states(algorithm, slots)
    for slot in slots:
        algorithm.env_runner_group.foreach_env_runner(
            lambda runner, slot=slot, state=states[slot]: runner.module[slot].set_state(state),
            local_env_runner=True)


def _book(algorithm, league: LeagueSettings) -> list[Slot]:
    return on_learner(algorithm, lambda learner: read_book(learner, league))


def _records(algorithm) -> dict[str, Record]:
    """The matchmaking book: member -> Record."""
    return on_learner(algorithm, lambda learner: module_of(learner, MATCHMAKING_MODULE).records())


def filled_slots(algorithm, curriculum) -> tuple[str, ...]:
    """The filled snapshot slots of `curriculum`'s league (none without a league)."""
    return members(_book(algorithm, curriculum.league)) if curriculum.league else ()


def exploiter_of(curriculum) -> tuple[str, ...]:
    """The league's exploiter module, if `curriculum`'s league has one."""
    league = curriculum.league
    return (EXPLOITER,) if league is not None and league.exploiter else ()


def matched(curriculum, stage) -> bool:
    """Whether `stage` plays a league that meets the learner by prioritized matchmaking."""
    league = curriculum.league
    return (league is not None and league.prioritized
            and (stage.self_play or isinstance(stage.opponent, tuple)))


def league_opponent(algorithm, curriculum, stage):
    """Who the learner meets in `stage`: its opponent or league, and in a self-play stage also
    the exploiter and the filled snapshot slots."""
    if not stage.self_play:
        return stage.opponent
    return (*stage.opponents, *exploiter_of(curriculum), *filled_slots(algorithm, curriculum))


def _priorities(curriculum, records: dict, opponent: tuple[str, ...]) -> list[float]:
    league = curriculum.league
    return [priority(records[name], league.priority_power, league.priority_floor)
            for name in opponent]


def league_weights(algorithm, curriculum, stage, opponent) -> tuple[float, ...] | None:
    """Each member's matchmaking weight (curriculum/matchmaking.py) in `stage`, None where
    the stage's opponents take plain turns."""
    if not matched(curriculum, stage):
        return None
    return tuple(_priorities(curriculum, _records(algorithm), opponent))


class LeagueCallback(RLlibCallback):
    """After each iteration: the league games of the curriculum `curriculum` (a shipped name or
    a file) into the matchmaking book and the gates, a filled slot or restarted exploiter onto
    the env runners, and the result's `league` and `matchmaking` entries (module docstring).
    It runs before the stage's callback (rl/stages.py), which then maps the new members."""

    def __init__(self, curriculum: str):
        super().__init__()
        self.curriculum = load_curriculum(curriculum)

    def _match(self, algorithm, runners: dict) -> None:
        """The iteration's results per league member into the matchmaking book."""
        results = {}
        for name in self.curriculum.league_members():
            games = count(runners, f"league_games_vs_{name}")
            if games:
                wins, losses = (count(runners, f"league_{key}_vs_{name}")
                                for key in ("wins", "losses"))
                results[name] = (wins, losses, games - wins - losses)
        halflife = self.curriculum.league.priority_halflife
        on_every_learner(algorithm, lambda learner: module_of(
            learner, MATCHMAKING_MODULE).add(results, halflife))

    def _matchmaking(self, algorithm, opponent: tuple[str, ...]) -> dict:
        """Each member's share of the coming games, win-rate estimate and decayed games."""
        records = _records(algorithm)
        weights = _priorities(self.curriculum, records, opponent)
        return {name: {"share": weight / sum(weights), "win_rate": records[name].win_rate,
                       "games": records[name].games}
                for name, weight in zip(opponent, weights, strict=True)}

    def _gate(self, algorithm, runners: dict, episodes: int) -> dict:
        """The iteration's league games into the gate, and the exploiter's games against the
        learner into its own; a filled slot goes to the env runners (and, under prioritized
        matchmaking, starts a new record), and so does a restarted exploiter."""
        league = self.curriculum.league
        wins, games = count(runners, "league_wins"), count(runners, "league_games")
        filled = on_every_learner(
            algorithm, lambda learner: gate_step(learner, league, wins, games, episodes))
        self._new_member(algorithm, filled)
        entry = {}
        if league.exploiter:  # its wins are the learner's losses against it
            wins, games = (count(runners, f"league_{key}_vs_{EXPLOITER}")
                           for key in ("losses", "games"))
            joined = on_every_learner(algorithm, lambda learner: exploiter_step(
                learner, league, wins, games, episodes))
            self._new_member(algorithm, joined)
            if joined:  # restarted from the learner
                share_modules(algorithm, [EXPLOITER])
            block_wins, block_games = on_learner(
                algorithm, lambda learner: module_of(
                    learner, MATCHMAKING_MODULE).exploiter.tolist())
            entry["exploiter"] = {"filled": joined, "gate_wins": block_wins,
                                  "gate_games": block_games}
        book = _book(algorithm, league)
        block = next_slot(book)
        return {"snapshots": len(members(book)), "filled": filled, "gate_games": block.games,
                "gate_win_rate": block.wins / block.games if block.games else float("nan"),
                "members": list(members(book)), **entry}

    def _new_member(self, algorithm, slot: str | None) -> None:
        """A slot just filled: a new record under prioritized matchmaking, and its weights on
        every env runner."""
        if slot is None:
            return
        if self.curriculum.league.prioritized:
            on_every_learner(algorithm,
                             lambda learner: module_of(learner, MATCHMAKING_MODULE).forget(slot))
        share_modules(algorithm, [slot])

    def on_train_result(self, *, algorithm, result, **kwargs) -> None:
        if self.curriculum.league is None:
            return
        runners = result[ENV_RUNNER_RESULTS]
        episodes = count(runners, NUM_EPISODES_LIFETIME)
        before = self.curriculum.stages[
            self.curriculum.stage_at(episodes - count(runners, NUM_EPISODES))]
        if matched(self.curriculum, before):
            self._match(algorithm, runners)  # before the gate, which may restart a record
        if before.self_play:
            result["league"] = self._gate(algorithm, runners, episodes)
        stage = self.curriculum.stages[self.curriculum.stage_at(episodes)]
        if matched(self.curriculum, stage):
            result["matchmaking"] = self._matchmaking(
                algorithm, league_opponent(algorithm, self.curriculum, stage))
