"""Prioritized matchmaking: the learner meets most often the league members it fails to beat.

This is AlphaStar's prioritized fictitious self-play (Vinyals et al., Nature 2019), retold for
a league of fixed opponents and self-play snapshots. Each member m carries a record of the
learner's games against it: wins, losses and ties, each game's weight halving every
`halflife` later games against m, so the record follows the learner as it changes. The
learner's win rate against m is estimated as wins / (games + 1): a member never met counts as
unbeaten, so a new snapshot is played at once. Ties count as failures: beating a careful team,
not drawing with it, is the point. A member's weight is

    max(floor, (1 - win rate) ** power)

and the members are met in proportion to their weights. The floor keeps every member in play
(none is forgotten once beaten); the power sharpens the focus on the hardest ones (AlphaStar's
f_hard, with power 2 for its main agents).

Who plays next is decided without randomness, by smooth weighted round robin (the rule nginx
balances servers with): each turn every member's credit grows by its weight, the member with
the most credit plays, and its credit falls by the total weight. Over any stretch of turns
each member plays its share to within one turn, and a seeded run replays exactly. With equal
weights it is plain round robin, the uniform league's order (curriculum/mapping.py).

No Ray, no torch: the curriculum checker and the seat mapping use this module; the record's
home in checkpoints is `rl/league.MatchmakingModule`.
"""

from __future__ import annotations

from dataclasses import dataclass

MATCHMAKING = ("uniform", "prioritized")


@dataclass(frozen=True)
class Record:
    """The learner's decayed results against one member."""
    wins: float = 0.0
    losses: float = 0.0
    ties: float = 0.0

    @property
    def games(self) -> float:
        return self.wins + self.losses + self.ties

    @property
    def win_rate(self) -> float:
        """Wins over games plus one: a member never met counts as unbeaten."""
        return self.wins / (self.games + 1.0)

    def add(self, wins: int, losses: int, ties: int, halflife: float) -> Record:
        """This record after `wins + losses + ties` new games: the old ones fade by half per
        `halflife` new games, then the new ones count in full."""
        fade = 0.5 ** ((wins + losses + ties) / halflife)
        return Record(self.wins * fade + wins, self.losses * fade + losses,
                      self.ties * fade + ties)


def priority(record: Record, power: float, floor: float) -> float:
    """A member's weight (module docstring)."""
    return max(floor, (1.0 - record.win_rate) ** power)


def shares(records: list[Record], power: float, floor: float) -> list[float]:
    """The share of turns each member gets: its weight over the total."""
    weights = [priority(record, power, floor) for record in records]
    total = sum(weights)
    return [weight / total for weight in weights]


class WeightedTurns:
    """Smooth weighted round robin over members (module docstring); `weights` may change
    between turns (the league's records after each iteration)."""

    def __init__(self, members: int):
        self.credit = [0.0] * members

    def next(self, weights: list[float] | tuple[float, ...]) -> int:
        """The index of the member that plays the next turn."""
        if len(weights) != len(self.credit):
            self.credit = [0.0] * len(weights)  # the league changed: start even
        self.credit = [credit + weight for credit, weight in zip(self.credit, weights, strict=True)]
        chosen = max(range(len(weights)), key=self.credit.__getitem__)
        self.credit[chosen] -= sum(weights)
        return chosen
