"""`python -m rllib_pommer.serve --policy NAME`: one agent of a policy over the 2018 competition's
HTTP protocol (see `rllib_pommer.serving`), like one competition container.

The server plays one seat at a time: a team needs two servers on two ports. It binds to loopback
unless `--host` says otherwise (use `--host 0.0.0.0` only inside a container). The first line on
stdout is `serving NAME on http://HOST:PORT` (with `--port 0` the port is picked by the system).

The command exits as soon as the server stops (/shutdown, SIGINT or SIGTERM), skipping the
interpreter's teardown of torch and numba, which takes seconds on a busy machine while whoever
stopped the server waits for the process to end.

Seeds: a caller may add `"seed"` to /init_agent (our extension; an integer, or a numpy bit-generator
state, which is what our arena's `http` policies send). Otherwise game k started by this server
(counting /init_agent and /episode_end) seeds the agent with `default_rng([--seed, k])`.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
import time
from typing import NoReturn

import torch

from .serving.app import DEFAULT_PORT, make_app, serve_until_stopped
from .serving.policy_host import PolicyHost
from .util.errors import report_error


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.serve", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--policy", required=True, help="policy name or file")
    parser.add_argument("--filters", default="", help="e.g. jitter,action")
    parser.add_argument("--host", default="127.0.0.1", help="address to bind (default: loopback)")
    parser.add_argument("--port", type=int, default=DEFAULT_PORT)
    parser.add_argument("--seed", type=int, default=0, help="seeds games sent without a seed")
    args = parser.parse_args(argv)
    # One observation per request: torch's intra-op threads cannot help a batch of one, and beside
    # other busy processes they spin against them (docs/measurements.md).
    torch.set_num_threads(1)
    if not 0 <= args.port < 65536:
        return report_error(f"--port must be in 0..65535, got {args.port}")
    try:
        host = PolicyHost(args.policy, [f for f in args.filters.split(",") if f], args.seed)
    except ValueError as exc:
        return report_error(exc)
    started = time.perf_counter()
    host.warm_up()  # before /ping answers: a pinging runner may start the game at once
    print(f"{args.policy} warmed up in {time.perf_counter() - started:.1f} s", file=sys.stderr)

    def announce(port: int) -> None:
        print(f"serving {args.policy} on http://{args.host}:{port}", flush=True)

    try:
        asyncio.run(serve_until_stopped(make_app(host), args.host, args.port, announce))
    except OSError as exc:
        return report_error(f"cannot serve on {args.host}:{args.port} ({exc})")
    _exit_at_once()


def _exit_at_once() -> NoReturn:
    """End the process with status 0 now that the server has stopped (module docstring)."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


if __name__ == "__main__":
    sys.exit(main())
