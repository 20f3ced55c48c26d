"""What the training figures draw (Fig. 3, the stage table, a model card's training): plain data
that `runs/history.py` computes from a run's history, so viz/ draws runs without reading their
files.

A curve's point is the mean return over the last `WINDOW` episodes up to an iteration, restarted
at each curriculum phase; each iteration logs RLlib's mean over its last `RLLIB_WINDOW` episodes
(its default smoothing window, which our config leaves as is).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

WINDOW = 1000
RLLIB_WINDOW = 100
MEMBER_WINDOW = 200  # games against one league member that its curves average
OUTCOME_KEYS = ("win", "loss", "tie")


@dataclass
class TrainingCurve:
    """One run: per kept row, its own lifetime episodes, the rolling mean return and the phase;
    `start + episodes` counts the games from the imitation clone (Fig. 3's axis)."""

    name: str
    episodes: np.ndarray
    returns: np.ndarray
    stages: list[str]
    rewards: list[str]  # per row: "shaped", "raw" or "" (not known)
    wins: np.ndarray  # the learner's team's win rate, the same rolling mean (NaN: not logged)
    losses: np.ndarray
    kills: np.ndarray | None = None  # enemies its team killed per game, the same mean (NaN: not
    # logged; None: all NaN)
    bombs: np.ndarray | None = None  # bombs each learner agent laid per game, the same
    start: int = 0  # games pi had played before the run's first, counted from the imitation clone
    origin: str | None = None  # the shipped policy pi started from (None: not known)

    def __post_init__(self):
        for field in ("kills", "bombs"):
            if getattr(self, field) is None:
                setattr(self, field, np.full(len(self.episodes), np.nan))


@dataclass
class StageFigures:
    """One curriculum phase of a run, from its iterations' rows. Outcome rates and the override
    share are the episode-weighted means of the logged 100-episode means (NaN where not logged);
    explained variance is the value network's, mean of the phase's first and last 10 rows."""

    run: str
    stage: str
    iterations: int
    episodes: int
    env_steps: int
    seconds: float
    win: float
    loss: float
    tie: float
    override_share: float
    explained_variance: tuple[float, float]


@dataclass
class MemberCurves:
    """The learner against one league member, per kept row of its run: the win, loss and tie
    rates over its last `MEMBER_WINDOW` games against the member (NaN before the first), and
    the member's share of the coming games under prioritized matchmaking (NaN: uniform)."""

    win: np.ndarray
    loss: np.ndarray
    tie: np.ndarray
    share: np.ndarray


@dataclass
class LeagueCurves:
    """One league run, member by member, over its lifetime episodes."""

    name: str
    episodes: np.ndarray
    members: dict[str, MemberCurves]


@dataclass
class Training:
    """The training of some trials, as the figures draw it: the trial folders it was read from,
    one curve per trial, the figures of every phase of every trial, and the member curves of
    the trials that played a league."""

    trials: list[Path]
    curves: list[TrainingCurve]
    stages: list[StageFigures]
    leagues: list[LeagueCurves] = dataclasses.field(default_factory=list)


def phases(stages: list[str]) -> list[tuple[int, int, str]]:
    """(start, end, stage) of each run of equal consecutive stages."""
    starts = [k for k in range(len(stages)) if k == 0 or stages[k] != stages[k - 1]]
    ends = starts[1:] + [len(stages)]
    return [(start, end, stages[start]) for start, end in zip(starts, ends, strict=True)]
