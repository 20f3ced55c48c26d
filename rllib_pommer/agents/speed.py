"""How fast agents play: SimpleAgent for `bench agents` (protocol (b) of docs/measurements.md)
and the search agent's time per decision for `bench search`.

One run of protocol (b) plays `GAMES_PER_RUN` games of four SimpleAgents, game g of run r seeded
2000 + 1000 r + g, and returns (steps/s, games/s) over the whole loop including reset: once with
one `SimpleAgent` object per seat deciding per call (the reference's shape), once with the batched
kernel deciding for every seat of every game in one call per step.

`decision_times` plays a policy against another, one game after another in this process, and
times each of the first policy's decisions alone (from the observation to the action) in CPU
time of the deciding thread, which is the wall time on a core of its own, but not inflated when
other work shares the cores.
"""

from __future__ import annotations

import time

import numpy as np

from ..game.constants import NUM_AGENTS, TEAM_PRESET
from ..game.engine import Game, Games
from ..game.state import A_ALIVE
from .registry import make_agent
from .simple import SimpleAgent, new_memory, simple_actions

GAMES_PER_RUN = 20


def _seeds(run: int) -> list[int]:
    return [2000 + 1000 * run + g for g in range(GAMES_PER_RUN)]


def simple_objects_run(run: int) -> tuple[float, float]:
    """Protocol (b) with one SimpleAgent object per seat and the single-game API."""
    start = time.perf_counter()
    steps = 0
    for seed in _seeds(run):
        game = Game(TEAM_PRESET)
        obs = game.reset(seed)
        agents = [SimpleAgent() for _ in range(NUM_AGENTS)]
        for seat, agent in enumerate(agents):
            agent.reset(seat, int(TEAM_PRESET.game_type), np.random.default_rng([seed, seat]))
        done = False
        while not done:
            alive = game.state.agents[0, :, A_ALIVE] != 0
            actions = [agents[s].act(obs.select(s)) if alive[s] else 0 for s in range(NUM_AGENTS)]
            obs, _, done, _ = game.step(actions)
            steps += 1
    total = time.perf_counter() - start
    return steps / total, GAMES_PER_RUN / total


def simple_batched_run(run: int) -> tuple[float, float]:
    """Protocol (b) with the batched engine and one batched SimpleAgent call per step."""
    start = time.perf_counter()
    games = Games(GAMES_PER_RUN, TEAM_PRESET)
    games.reset(_seeds(run))
    memory = new_memory(NUM_AGENTS * GAMES_PER_RUN, np.random.default_rng(run))
    steps = 0
    while not games.done.all():
        active = games.alive & ~games.done[:, None]
        actions = simple_actions(games.obs.agent_rows(), memory, active.ravel())
        steps += int((~games.done).sum())
        games.step(actions.reshape(-1, NUM_AGENTS))
    total = time.perf_counter() - start
    return steps / total, GAMES_PER_RUN / total


SEARCH_GAMES = 100  # games `bench search` times


def decision_times(policy: str, vs: str, games: int) -> dict:
    """CPU time per decision of `policy` on two seats ({0, 2} in even games, {1, 3} in odd ones)
    against `vs`, over `games` games seeded 3000 + g: p50, p99 and max in milliseconds, the
    number of decisions, and the games per second of the whole loop (both teams deciding)."""
    times = []
    start = time.perf_counter()
    for g in range(games):
        game = Game(TEAM_PRESET)
        obs = game.reset(3000 + g)
        ours = (0, 2) if g % 2 == 0 else (1, 3)
        agents = [make_agent(policy if s in ours else vs) for s in range(NUM_AGENTS)]
        for seat, agent in enumerate(agents):
            agent.reset(seat, int(TEAM_PRESET.game_type), np.random.default_rng([g, seat]))
        done = False
        while not done:
            alive = game.state.agents[0, :, A_ALIVE] != 0
            actions = [0] * NUM_AGENTS
            for s in np.flatnonzero(alive):
                began = time.thread_time()
                actions[s] = agents[s].act(obs.select(s))
                if s in ours:
                    times.append(time.thread_time() - began)
            obs, _, done, _ = game.step(actions)
    total = time.perf_counter() - start
    ms = np.array(times) * 1000
    return {"p50_ms": float(np.percentile(ms, 50)), "p99_ms": float(np.percentile(ms, 99)),
            "max_ms": float(ms.max()), "decisions": len(ms), "games_per_s": games / total}
