"""Who plays which seat: the policy mapping of one curriculum stage.

The learner's seat cycles 0, 1, 2, 3 over the episodes an env runner starts, so it plays both
teams ({0, 2} and {1, 3}, which differ: the reference shows a seat effect) and both corners of
each; its teammate sits across (seat + 2) and the two other seats get the stage's opponent. A
stage may name a league of opponents instead of one: they take turns by whole seat cycles
(episodes 0-3 the first, 4-7 the second, ...), so every opponent meets the learner in every
seat as often as the others. A league under prioritized matchmaking (curriculum/matchmaking.py)
carries `weights`, one per opponent: whole seat cycles still go to one opponent each, but who
gets the next cycle follows the weights (smooth weighted round robin, no randomness), and the
callback updates the weights in place after every iteration. Module ids are the policy names
themselves, plus "learner"; a teammate named "learner" makes both seats of the team the
trained module. No Ray here: a mapping is a plain callable, pickled by its import path into the
algorithm config (and so into checkpoints).

The curriculum callback installs a new `SeatMapping` on the env runners only when the stage
changes (`stage` tells), so the seat cycle is not restarted every iteration.
"""

from __future__ import annotations

from .matchmaking import WeightedTurns
from .names import LEARNER

SEAT_CYCLE = (0, 1, 2, 3)
_REMEMBERED_EPISODES = 256  # plenty for the episodes a runner's vector env has open at once


class SeatMapping:
    """The policy mapping of one stage: module id for (agent id, episode), see above.
    `opponent` is one policy name or a league of them; `weights`, one per opponent of a
    league, choose who plays each seat cycle (None: they take turns in order)."""
    def __init__(self, stage: int, teammate: str, opponent: str | tuple[str, ...],
                 weights: tuple[float, ...] | None = None):
        self.stage, self.teammate, self.opponent = stage, teammate, opponent
        self.weights = weights
        self._numbers: dict[str, int] = {}  # episode id -> its number in this runner's order
        self._episodes = 0
        self._turns: dict[int, str] = {}  # seat cycle -> its opponent, under weights
        self._weighted = WeightedTurns(len(self.opponents))

    @property
    def opponents(self) -> tuple[str, ...]:
        return (self.opponent,) if isinstance(self.opponent, str) else self.opponent

    def __setstate__(self, state: dict) -> None:
        # Mappings pickled before leagues kept each episode's seat, which is its number mod 4;
        # those pickled before prioritized matchmaking had no weights.
        state.setdefault("_numbers", state.pop("_seats", {}))
        state.setdefault("weights", None)
        state.setdefault("_turns", {})
        self.__dict__.update(state)
        if "_weighted" not in state:
            self._weighted = WeightedTurns(len(self.opponents))

    def _number(self, episode_id: str) -> int:
        if episode_id not in self._numbers:
            self._numbers[episode_id] = self._episodes
            self._episodes += 1
            if len(self._numbers) > _REMEMBERED_EPISODES:
                del self._numbers[next(iter(self._numbers))]
        return self._numbers[episode_id]

    def learner_seat(self, episode_id: str) -> int:
        return SEAT_CYCLE[self._number(episode_id) % len(SEAT_CYCLE)]

    def opponent_of(self, episode_id: str) -> str:
        if isinstance(self.opponent, str):
            return self.opponent
        turn = self._number(episode_id) // len(SEAT_CYCLE)
        if self.weights is None:
            return self.opponent[turn % len(self.opponent)]
        if turn not in self._turns:
            self._turns[turn] = self.opponent[self._weighted.next(self.weights)]
            if len(self._turns) > _REMEMBERED_EPISODES:
                del self._turns[next(iter(self._turns))]
        return self._turns[turn]

    def __call__(self, agent_id, episode, **kwargs) -> str:
        seat = self.learner_seat(episode.id_)
        if agent_id == seat:
            return LEARNER
        return self.teammate if agent_id % 2 == seat % 2 else self.opponent_of(episode.id_)
