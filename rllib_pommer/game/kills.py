"""Who killed whom: the cause of each death from the engine's kill credit.

The engine (`engine.Games.killers`) records, for every agent that dies, the bit mask of the agents
whose fire it died in: a bomb burns in the name of the agent who laid it (a kick does not change
that) and, when another fire set it off, of everyone that fire burned for, down the whole chain;
flames that linger keep the credit of the blast that lit them; where blasts overlap on a cell,
their credits add up (docs/rules.md §9). From the mask, each death has one cause,
seen from the victim:

* "self": the victim's own bomb is among them, whoever else's fire also reached it (the
  reference's statistics count such a death as the agent's own, and it keeps a kill from being
  credited for a blast the victim stood in);
* "enemy": else an agent of the other team is among them (a kill for that team);
* "teammate": else only the victim's teammate (a team kill);
* "unknown": an empty mask: the fire predates what the engine saw (a state loaded mid-game).

Plain Python over small integer arrays: the arena, the envs and the training callbacks all read
it, one game at a time.
"""

from __future__ import annotations

from collections.abc import Sequence

from .constants import NUM_AGENTS

CAUSES = ("self", "teammate", "enemy", "unknown")


def killer_seats(mask: int) -> list[int]:
    """The seats in a kill-credit bit mask, in order."""
    return [seat for seat in range(NUM_AGENTS) if int(mask) >> seat & 1]


def death_cause(victim: int, mask: int) -> str:
    """The cause of `victim`'s death from its kill-credit mask (module docstring)."""
    seats = killer_seats(mask)
    if not seats:
        return "unknown"
    if victim in seats:
        return "self"
    if any(seat % 2 != victim % 2 for seat in seats):
        return "enemy"
    return "teammate"


def kills_of_team(seat: int, died: Sequence[bool], killers: Sequence[int]) -> int:
    """How many agents of the other team than `seat`'s died by an "enemy" cause, that is were
    killed by `seat`'s team."""
    return sum(1 for victim in range(NUM_AGENTS)
               if victim % 2 != seat % 2 and died[victim]
               and death_cause(victim, killers[victim]) == "enemy")


def deaths_by_cause(seats: Sequence[int], died: Sequence[bool],
                    killers: Sequence[int]) -> dict[str, int]:
    """How many of `seats` died of each cause."""
    counts = dict.fromkeys(CAUSES, 0)
    for seat in seats:
        if died[seat]:
            counts[death_cause(seat, killers[seat])] += 1
    return counts
