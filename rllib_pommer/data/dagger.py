"""DAgger play: the clone acts, SimpleAgent labels the states the clone visits.

Behaviour cloning learns from SimpleAgent's own games, but the clone, once it errs, reaches states
SimpleAgent seldom visits and has never been shown what to do there. DAgger (Ross, Gordon and
Bagnell 2011) closes that gap: the clone plays, and the expert says what it would have done at
every state the clone visited; those labels join the dataset and the clone is trained again.

Game g of a DAgger shard is played as in the arena (`game_seeds(seed, g)`): the clone's team takes
seats {0, 2} or {1, 3} in turn, against `opponents[g % len(opponents)]` ("simple" or "static").
Each clone seat has a shadow SimpleAgent memory, seeded from the seat's stream, that decides at
every step as if it were playing: its decision is the sample's recorded action (so the shadow's
memory of where it wandered and which way it approached follows the clone's trajectory), and its
counts over `label_draws` further draws are the soft target. Only the clone's decisions are
recorded; the games depend only on (seed, g, the clone's weights).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..agents.simple import simple_action_counts, simple_actions
from ..game.constants import NUM_AGENTS, Action
from ..game.observation import Observation
from .expert import BATCH_GAMES, GameSlots
from .schema import Samples

OPPONENTS = ("simple", "static")
TEAM_SEATS = ((0, 2), (1, 3))

Actor = Callable[[Observation], np.ndarray]  # observations (B,) -> actions (B,)


def seating(game: int, opponents: tuple[str, ...]) -> tuple[str, tuple[int, int]]:
    """The opponent and the clone's seats of game `game`."""
    cycle = len(opponents)
    return opponents[game % cycle], TEAM_SEATS[(game // cycle) % 2]


def check_setup(opponents: tuple[str, ...], label_draws: int) -> None:
    """ValueError unless DAgger can be played against `opponents` with these label draws."""
    if label_draws <= 0:
        raise ValueError("DAgger data need --label-draws (the expert's labels)")
    unknown = sorted(set(opponents) - set(OPPONENTS))
    if unknown or not opponents:
        raise ValueError(f"DAgger opponents {list(opponents)}: each must be one of "
                         f"{list(OPPONENTS)}")


def play_dagger_games(seed: int, games: range, act: Actor, opponents: tuple[str, ...],
                      label_draws: int, batch_games: int = BATCH_GAMES) -> Samples:
    """The clone's decisions in games `games`, labelled by its shadow SimpleAgents."""
    check_setup(opponents, label_draws)
    slots = min(batch_games, len(games))
    clone_seat = np.zeros((slots, NUM_AGENTS), bool)
    simple_seat = np.zeros((slots, NUM_AGENTS), bool)

    def seat(slot: int, game: int) -> None:
        opponent, seats = seating(game, opponents)
        clone_seat[slot] = [s in seats for s in range(NUM_AGENTS)]
        simple_seat[slot] = ~clone_seat[slot] & (opponent == "simple")

    play = GameSlots(seed, games, batch_games, on_start=seat)
    recorded: list[Samples] = []
    while play.playing:
        active = play.active()
        rows = play.engine.obs.agent_rows()
        clones = active & clone_seat.ravel()
        counts = simple_action_counts(rows, play.memory, label_draws, clones)
        labels = simple_actions(rows, play.memory, active & (clone_seat | simple_seat).ravel())
        actions = labels.copy()
        actions[~simple_seat.ravel()] = int(Action.STOP)
        clone = np.flatnonzero(clones)
        if len(clone):
            actions[clone] = act(rows.select(clone))
        recorded.append(play.samples(rows, labels, counts).take(clone))
        play.step(actions)
    return Samples.concatenate(recorded)
