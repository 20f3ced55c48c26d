"""Round-trip latency of /action for a served policy, from a separate client process.

    python benchmarks/serve_latency.py [--policy simple] [--filters jitter,action]
        [--requests 10000] [--warmup 200] [--json]

Starts `python -m rllib_pommer.serve` on a free loopback port, waits for /ping, then plays the
recorded observations of tests/reference/games_public.jsonl.gz in order, one request at a time
as the competition's runner did: per game one seat (game i: seat (i + pass) % 4), /init_agent, then
that seat's observation before every step while it is alive. Each request is timed from sending
to the decoded answer. Prints p50, p99 and max over `--requests` requests after `--warmup` untimed
ones, then stops the server with /shutdown. The goal is p99 <= 10 ms (the rules allowed 100 ms);
exit code 1 if it is missed.
"""

from __future__ import annotations

import argparse
import gzip
import json
import selectors
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import requests

GAMES = Path(__file__).resolve().parents[1] / "tests" / "reference" / "games_public.jsonl.gz"
STARTUP_SECONDS = 60.0
PASSES = 8  # over the recorded games, each with other seats; about 12,000 requests per pass
GAME_TYPES = {"PommeTeamCompetition-v0": 2, "PommeFFACompetition-v0": 1}


def seat_requests(path: Path) -> Iterator[tuple[str, dict]]:
    """(endpoint, body) pairs of the recorded games, pass after pass."""
    for pass_index in range(PASSES):
        with gzip.open(path, "rt") as lines:
            for game_index, line in enumerate(lines):
                game = json.loads(line)
                seat = (game_index + pass_index) % 4
                yield "init_agent", {"id": str(seat), "game_type": str(GAME_TYPES[game["env_id"]])}
                seen = [game["initial_observations"]] + [s["observations"] for s in game["steps"]]
                for observations in seen[:-1]:  # the last ones come after the final step
                    obs = observations[seat]
                    if 10 + seat not in obs["alive"]:
                        break
                    yield "action", {"obs": json.dumps(obs), "action_space": "6"}


def start_server(policy: str, filters: str) -> tuple[subprocess.Popen, str]:
    """The server process and its base URL, once it answers /ping."""
    command = [sys.executable, "-m", "rllib_pommer.serve", "--policy", policy,
               "--filters", filters, "--port", "0"]
    server = subprocess.Popen(command, stdout=subprocess.PIPE, text=True)
    deadline = time.monotonic() + STARTUP_SECONDS
    with selectors.DefaultSelector() as selector:
        selector.register(server.stdout, selectors.EVENT_READ)
        if not selector.select(timeout=STARTUP_SECONDS):
            server.kill()
            raise SystemExit(f"the server printed nothing within {STARTUP_SECONDS:.0f} s")
    banner = server.stdout.readline()
    if not banner.startswith("serving "):
        server.kill()
        raise SystemExit(f"the server did not start: {banner!r}")
    url = banner.split(" on ", 1)[1].strip()
    while time.monotonic() < deadline:
        try:
            if requests.get(f"{url}/ping", timeout=1).ok:
                return server, url
        except requests.ConnectionError:
            time.sleep(0.1)
    server.kill()
    raise SystemExit(f"{url} did not answer /ping within {STARTUP_SECONDS:.0f} s")


def measure(url: str, requests_wanted: int, warmup: int) -> np.ndarray:
    """Seconds per timed /action request."""
    session = requests.Session()
    seconds = []
    for endpoint, body in seat_requests(GAMES):
        start = time.perf_counter()
        response = session.post(f"{url}/{endpoint}", json=body, timeout=10)
        answer = response.json()
        elapsed = time.perf_counter() - start
        response.raise_for_status()
        if endpoint == "action":
            if answer["action"] not in range(6):
                raise SystemExit(f"bad answer {answer}")
            seconds.append(elapsed)
            if len(seconds) == warmup + requests_wanted:
                return np.array(seconds[warmup:])
    raise SystemExit(f"{PASSES} passes over the recorded games hold only {len(seconds)} requests")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--policy", default="simple")
    parser.add_argument("--filters", default="")
    parser.add_argument("--requests", type=int, default=10_000)
    parser.add_argument("--warmup", type=int, default=200)
    parser.add_argument("--json", action="store_true", help="also print a JSON line")
    args = parser.parse_args()
    if not GAMES.exists():
        print(f"error: recorded games not found at {GAMES}", file=sys.stderr)
        return 2
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))  # so `finally` stops the server
    server, url = start_server(args.policy, args.filters)
    try:
        ms = measure(url, args.requests, args.warmup) * 1000
    finally:
        try:
            requests.post(f"{url}/shutdown", timeout=5)
            server.wait(timeout=10)
        except (requests.RequestException, subprocess.TimeoutExpired):
            server.kill()
    p50, p99 = np.percentile(ms, [50, 99])
    name = args.policy + (f" +{args.filters}" if args.filters else "")
    print(f"{name}: {len(ms)} sequential /action requests over loopback "
          f"({args.warmup} untimed warm-up): p50 {p50:.2f} ms, p99 {p99:.2f} ms, "
          f"max {ms.max():.2f} ms, mean {ms.mean():.2f} ms")
    if args.json:
        print(json.dumps({"policy": args.policy, "filters": args.filters, "requests": len(ms),
                          "p50_ms": p50, "p99_ms": p99, "max_ms": float(ms.max()),
                          "mean_ms": float(ms.mean())}))
    return 0 if p99 <= 10 else 1


if __name__ == "__main__":
    sys.exit(main())
