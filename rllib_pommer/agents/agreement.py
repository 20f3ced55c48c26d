"""How often a policy picks the reference SimpleAgent's recorded action (docs/measurements.md).

By default the policy is our SimpleAgent (the fidelity check of the compiled kernel); any named
policy can be measured by the same ruler, e.g. an imitation clone (greedy if its file says so).

The reference SimpleAgent breaks ties with Python's global random stream, so its recorded actions
cannot all be reproduced. The decisions file says, per decision, how many of 8 differently seeded
reference agents chose the recorded action. A faithful clone should agree on (nearly) every
decision where all 8 did ("stable"), and overall about as often as the reference agrees with itself.
"""

from __future__ import annotations

import gzip
import json
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..game.constants import Item
from ..game.serialize import load_observation
from .registry import make_agent

ALL_AGREED = 8


class AgreementResult(NamedTuple):
    """What `measure_agreement` found: the line `replay agree` prints, and the reference's own."""
    agreement: float  # A: fraction of all decisions equal to the recorded action
    decisions: int  # N
    stable_agreement: float  # S: the same fraction over decisions where all 8 references agreed
    stable_decisions: int  # K
    reference_mean: float  # the reference's own mean agreement (the file's `mean_agreement`)


def format_line(result: AgreementResult) -> str:
    return (
        f"agreement {result.agreement:.4f} on {result.decisions} decisions; "
        f"stable {result.stable_agreement:.4f} on {result.stable_decisions} decisions"
    )


def _games(games_path: Path, wanted: set[int]) -> Iterator[tuple[int, dict]]:
    """(line index, game) for the wanted lines only, streamed; other lines are never parsed."""
    remaining = set(wanted)
    with gzip.open(games_path, "rt", encoding="utf-8") as lines:
        for index, line in enumerate(lines):
            if index in remaining:
                remaining.discard(index)
                yield index, json.loads(line)
            if not remaining:
                return
    raise ValueError(f"{games_path}: no game_index {min(remaining)} (the file is shorter)")


def _seat_agreement(game: dict, game_index: int, row: dict,
                    policy: str) -> tuple[int, int, int]:
    """(agreed, stable agreed, stable decisions) for one SimpleAgent seat of one game."""
    agent_id, digits = row["agent_id"], row["agree_of_8"]
    where = f"game_index {game_index}, agent_id {agent_id}"
    if game["seed"] != row["seed"]:
        raise ValueError(f"{where}: decisions row has seed {row['seed']}, game has {game['seed']}")
    if not game.get("has_observations"):
        raise ValueError(f"{where}: the game has no recorded observations")
    agent = make_agent(policy)
    agent.reset(
        agent_id,
        game["initial_observations"][agent_id]["game_type"],
        np.random.default_rng([game["seed"], agent_id]),
    )
    agreed = stable_agreed = stable = decision = 0
    observations = game["initial_observations"]
    for step in game["steps"]:
        obs = observations[agent_id]
        observations = step["observations"]
        if Item.AGENT0 + agent_id not in obs["alive"]:
            continue
        if decision >= len(digits):
            raise ValueError(f"{where}: more decisions than the {len(digits)} agree_of_8 digits")
        same = agent.act(load_observation(obs, agent_id)) == step["actions"][agent_id]
        agreed += same
        if digits[decision] == str(ALL_AGREED):
            stable += 1
            stable_agreed += same
        decision += 1
    if decision != len(digits):
        raise ValueError(f"{where}: {decision} decisions but {len(digits)} agree_of_8 digits")
    return agreed, stable_agreed, stable


def measure_agreement(games_path: str | Path, decisions_path: str | Path,
                      policy: str = "simple") -> AgreementResult:
    """Replay every SimpleAgent seat of the decisions file through a fresh agent of `policy`.

    Each seat's agent is seeded from (game seed, agent id), so the result is reproducible.
    """
    decisions = json.loads(Path(decisions_path).read_text(encoding="utf-8"))
    rows_by_game: dict[int, list[dict]] = {}
    for row in decisions["rows"]:
        rows_by_game.setdefault(row["game_index"], []).append(row)
    agreed = stable_agreed = stable = total = 0
    for game_index, game in _games(Path(games_path), set(rows_by_game)):
        for row in rows_by_game[game_index]:
            seat_agreed, seat_stable_agreed, seat_stable = _seat_agreement(game, game_index, row,
                                                                           policy)
            agreed += seat_agreed
            stable_agreed += seat_stable_agreed
            stable += seat_stable
            total += len(row["agree_of_8"])
    return AgreementResult(
        agreement=agreed / max(total, 1),
        decisions=total,
        stable_agreement=stable_agreed / max(stable, 1),
        stable_decisions=stable,
        reference_mean=float(decisions["mean_agreement"]),
    )
