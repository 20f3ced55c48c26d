"""How close a team comes to killing: distances, threats and their conversion, from replays.

    python -m rllib_pommer.evaluate --team ppo_league --vs ppo_cautious --games 200 \
        --record 200 --replays runs/threats/league.jsonl.gz --records runs/threats/league.csv
    python benchmarks/threats.py runs/threats/league.jsonl.gz [more replays ...]

A tie against a careful team can mean two things: the teams never meet, or they meet and no
bomb lands. From replays written by `evaluate --record` (team A on `seats_a`), per outcome of A
(win, loss, tie) and per replays file:

- near: the share of steps on which some agent of A stands within 2 cells (Manhattan) of a
  living enemy, and the mean of that nearest distance;
- bombs: bombs A's agents lay per agent per game, and the enemies' likewise;
- threats: A's bombs laid with a living enemy in their blast cross (as the engine draws it) at
  the step they appear, per game;
- converted: the share of those threats whose threatened enemy is dead within 12 steps (the
  bomb's life, 10 steps, and its flames): an upper bound on the threats that killed, since
  another bomb may have done it;
- trap chances: the steps at which one agent of A could lay a bomb where it stands that would
  leave a living enemy, not trapped yet, no way out while A's agents keep theirs (everybody
  then standing still, no other bomb laid: `agents/survival.escapes_if_bombing`), per game;
  taken: the share of those steps after which A laid a bomb.

Read only: the engine's records stay the source of the results. Not part of CI: an analysis.
"""

from __future__ import annotations

import argparse
import gzip
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

from rllib_pommer.agents.survival import escapes_if_bombing, rooms_under_threat
from rllib_pommer.game.blast import mark_blast
from rllib_pommer.game.constants import BOMB_LIFE_AT_LAYING
from rllib_pommer.game.engine import Game
from rllib_pommer.game.rewards import ROOM_HORIZON

REACH_STEPS = 12  # a bomb's 10 steps of life and its flames
LAID_LIFE = BOMB_LIFE_AT_LAYING - 1  # in the state of the step that laid it, ticked once
OUTCOMES = ("Win", "Loss", "Tie")


def _games(path: Path):
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt") as lines:
        for line in lines:
            yield json.loads(line)


def _in_cross(board: np.ndarray, bomb: tuple[int, int], strength: int,
              cell: tuple[int, int]) -> bool:
    """Whether `cell` lies in the blast cross of a bomb of `strength` at `bomb` on `board`, as
    the engine draws it (`game/blast.mark_blast`)."""
    mask = np.zeros(board.shape, np.uint8)
    mark_blast(board, mask, bomb[0], bomb[1], strength)
    return bool(mask[cell])


def game_threats(game: dict) -> dict:
    """The measures of one replayed game for team A (module docstring)."""
    ours = set(game["seats_a"])
    states = [step["state"] for step in game["steps"]]
    near = distance = 0
    threats: list[tuple[int, int]] = []  # (step, threatened enemy)
    bombs = {"ours": 0, "theirs": 0}
    death_step: dict[int, int] = {}
    for state in states:
        step, board = state["step_count"], np.array(state["board"])
        alive = {a["agent_id"]: tuple(a["position"]) for a in state["agents"] if a["is_alive"]}
        for a in state["agents"]:
            if not a["is_alive"]:
                death_step.setdefault(a["agent_id"], step)
        gaps = [abs(p[0] - q[0]) + abs(p[1] - q[1]) for a, p in alive.items() if a in ours
                for b, q in alive.items() if b not in ours]
        if gaps:
            near += min(gaps) <= 2
            distance += min(gaps)
        for bomb in state["bombs"]:
            if bomb["life"] < LAID_LIFE:  # laid before this step (a kicked bomb moves on)
                continue
            side = "ours" if bomb["bomber_id"] in ours else "theirs"
            bombs[side] += 1
            if side == "ours":
                threats += [(step, b) for b, q in alive.items() if b not in ours and
                            _in_cross(board, tuple(bomb["position"]), bomb["blast_strength"], q)]
    steps = max(len(states), 1)
    converted = sum(death_step.get(b, 10**9) - step <= REACH_STEPS for step, b in threats)
    chances, taken = trap_chances(states, ours)
    return {"near": near / steps, "distance": distance / steps, "bombs_ours": bombs["ours"] / 2,
            "bombs_theirs": bombs["theirs"] / 2, "threats": len(threats),
            "converted": converted, "chances": chances, "taken": taken,
            "winners": game["final_info"].get("winners", [])}


def _traps(escapes: np.ndarray, free: np.ndarray, ours: set[int]) -> bool:
    """Whether a bomb whose outcome is `escapes` traps a `free` enemy and spares team `ours`."""
    spared = all(escapes[a] != 0 for a in ours)  # 1, or -1: dead already
    return spared and any(escapes[e] == 0 and free[e] for e in range(len(escapes))
                          if e not in ours)


def trap_chances(states: list[dict], ours: set[int]) -> tuple[int, int]:
    """(trap chances, those taken) of team `ours` over a game's states (module docstring)."""
    game = Game()
    chances = taken = 0
    for state, after in zip(states, states[1:], strict=False):
        game.load(state)
        arrays = game.batch.state
        now = [array[0] for array in arrays]
        free = rooms_under_threat(*now, ROOM_HORIZON, 1, False) > 0  # not trapped yet
        if not any(_traps(escapes_if_bombing(*now, a, ROOM_HORIZON), free, ours) for a in ours):
            continue
        chances += 1
        taken += any(b["bomber_id"] in ours and b["life"] >= LAID_LIFE for b in after["bombs"])
    return chances, taken


def _outcome(game: dict, measures: dict) -> str:
    """A's outcome: Win if A's seats won, Loss if the others did, else Tie."""
    winners = set(measures["winners"])
    if not winners:
        return "Tie"
    return "Win" if winners <= set(game["seats_a"]) else "Loss"


def table(paths: list[Path]) -> str:
    lines = ["| replays | A's outcome | games | near (share of steps within 2) | mean nearest "
             "distance | bombs per agent, A / enemies | A's threats per game | converted | "
             "trap chances per game | taken |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for path in paths:
        groups: dict[str, list[dict]] = defaultdict(list)
        label = None
        for game in _games(path):
            label = label or f"{game['team']} vs {game['vs']}"
            measures = game_threats(game)
            groups[_outcome(game, measures)].append(measures)
        for outcome in OUTCOMES:
            rows = groups.get(outcome, [])
            if not rows:
                continue
            mean = {key: float(np.mean([r[key] for r in rows])) for key in
                    ("near", "distance", "bombs_ours", "bombs_theirs", "threats")}
            total = sum(r["threats"] for r in rows)
            share = sum(r["converted"] for r in rows) / total if total else float("nan")
            chances = sum(r["chances"] for r in rows)
            taken = sum(r["taken"] for r in rows) / chances if chances else float("nan")
            lines.append(f"| {label} | {outcome.lower()} | {len(rows)} | {mean['near']:.2f} | "
                         f"{mean['distance']:.1f} | {mean['bombs_ours']:.1f} / "
                         f"{mean['bombs_theirs']:.1f} | {mean['threats']:.1f} | {share:.2f} | "
                         f"{chances / len(rows):.1f} | {taken:.2f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/threats.py", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("replays", nargs="+", type=Path)
    args = parser.parse_args(argv)
    missing = [str(p) for p in args.replays if not p.is_file()]
    if missing:
        print(f"error: no replays file {missing[0]}", file=sys.stderr)
        return 2
    print(table(args.replays))
    return 0


if __name__ == "__main__":
    sys.exit(main())
