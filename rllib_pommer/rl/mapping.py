"""Who plays which seat: the policy mapping of one curriculum stage.

The learner's seat cycles 0, 1, 2, 3 over the episodes an env runner starts, so it plays both
teams ({0, 2} and {1, 3}, which differ: the reference shows a seat effect) and both corners of
each; its teammate sits across (seat + 2) and the two other seats get the stage's opponent.
Module ids are the policy names themselves, plus "learner"; a teammate named "learner" makes
both seats of the team the trained module. No Ray here: a mapping is a plain
callable, pickled by its import path into the algorithm config (and so into checkpoints).

The curriculum callback installs a new `SeatMapping` on the env runners only when the stage
changes (`stage` tells), so the seat cycle is not restarted every iteration.
"""

from __future__ import annotations

from .names import LEARNER

SEAT_CYCLE = (0, 1, 2, 3)
_REMEMBERED_EPISODES = 256  # plenty for the episodes a runner's vector env has open at once


class SeatMapping:
    """The policy mapping of one stage: module id for (agent id, episode), see above."""
    def __init__(self, stage: int, teammate: str, opponent: str):
        self.stage, self.teammate, self.opponent = stage, teammate, opponent
        self._seats: dict[str, int] = {}
        self._episodes = 0

    def learner_seat(self, episode_id: str) -> int:
        if episode_id not in self._seats:
            self._seats[episode_id] = SEAT_CYCLE[self._episodes % len(SEAT_CYCLE)]
            self._episodes += 1
            if len(self._seats) > _REMEMBERED_EPISODES:
                del self._seats[next(iter(self._seats))]
        return self._seats[episode_id]

    def __call__(self, agent_id, episode, **kwargs) -> str:
        seat = self.learner_seat(episode.id_)
        if agent_id == seat:
            return LEARNER
        return self.teammate if agent_id % 2 == seat % 2 else self.opponent
