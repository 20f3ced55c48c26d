"""`python -m rllib_pommer.play --team A --vs B`: play a seat of a Team game in the browser.

You sit on `--seat` (default 0) of team A; the other seat of your team plays `--teammate`
(default: policy A), both seats of the other team play policy B. Any policy name the arena takes
works (scripted, learned, a PPO run, an `http` remote agent). The command serves one game on
loopback (unless `--host` says otherwise) and prints its URL first; open it in a browser. Arrow
keys move, space lays a bomb, any other key plays Stop, and so does no key within the turn time
(`--turn-time SECONDS`, or `wait` to wait for you; also set on the page, with pause).

`--variant radio` plays TeamRadio: the agents hear their teammates' words and speak if they do
(a `_words` policy, a radio network); the page shows what your teammate says, and the digit keys
0-7 set the two words you send with every move (the first digit word 1, the next word 2).

The game ends with its result, or as a forfeit when the page is closed (or the command is
stopped); either way it is saved as a replay (`--out`, default play-<time>.jsonl.gz) for
`python -m rllib_pommer.replay html|render|verify`, and the command exits. `--out` is checked
before the game is served: it must end in .jsonl or .jsonl.gz, and an existing file is replaced
only with `--force` (a game stopped before its first move would otherwise replace a kept replay
with a forfeit). Should `--out` fail at the end (a full disk, a folder deleted meanwhile), the
game goes to a new file in the system's temporary folder, whose path is printed. Only one page
can hold the game: a second one is refused.
"""

from __future__ import annotations

import argparse
import asyncio
import sys
import time
from pathlib import Path

from .game.records import JSONL_SUFFIXES
from .playing.server import RECONNECT, make_app, parse_turn_time, serve_game
from .playing.session import HumanGame, PlaySpec
from .util.cli_options import non_negative_int
from .util.errors import report_error
from .util.outputs import check_output

DEFAULT_TURN_TIME = 0.5


def _turn_time(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        value = text  # "wait", or named as it is in the error
    try:
        return parse_turn_time(value)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rllib_pommer.play", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--team", required=True, help="policy of your team (your teammate)")
    parser.add_argument("--vs", required=True, help="policy of the other team")
    parser.add_argument("--seat", type=int, default=0, help="your seat, 0..3 (default 0)")
    parser.add_argument("--teammate", help="policy of your teammate (default: --team)")
    parser.add_argument("--seed", type=non_negative_int, default=0,
                        help="deals the board and the agents' random streams, as game 0 of "
                             "`evaluate --seed`")
    parser.add_argument("--variant", choices=("team", "radio"), default="team",
                        help="the game: Team, or TeamRadio with words (default %(default)s)")
    parser.add_argument("--host", default="127.0.0.1", help="address to bind (default: loopback)")
    parser.add_argument("--port", type=int, default=8080, help="0: any free port")
    parser.add_argument("--turn-time", type=_turn_time, default=DEFAULT_TURN_TIME,
                        metavar="SECONDS|wait", help="time for each move (default %(default)s)")
    parser.add_argument("--reconnect", type=float, default=RECONNECT, metavar="SECONDS",
                        help="how long a closed page (a reload) has to come back before the "
                        "game is forfeited; the clock waits meanwhile (default %(default)s)")
    parser.add_argument("--out", type=Path, help="the replay, .jsonl or .jsonl.gz "
                        "(default: play-<date>-<time>.jsonl.gz here)")
    parser.add_argument("--force", action="store_true", help="replace an existing --out file")
    args = parser.parse_args(argv)
    out = args.out or Path(time.strftime("play-%Y%m%d-%H%M%S.jsonl.gz"))
    try:
        if not 0 <= args.port < 65536:
            raise ValueError(f"--port must be in 0..65535, got {args.port}")
        if not 0 <= args.reconnect <= 3600:
            raise ValueError(f"--reconnect must be 0..3600 seconds, got {args.reconnect}")
        check_output(out, "--out", args.force, JSONL_SUFFIXES)
        game = HumanGame(PlaySpec(args.team, args.vs, args.seat, args.teammate, args.seed,
                                  args.variant))
    except ValueError as exc:
        return report_error(exc)

    def announce(port: int) -> None:
        print(f"play at http://{args.host}:{port}/", flush=True)

    try:
        table = asyncio.run(serve_game(make_app(game, out, args.turn_time, args.reconnect),
                                       args.host, args.port, announce))
    except OSError as exc:
        return report_error(f"cannot serve on {args.host}:{args.port} ({exc})")
    print(game.summary())
    for error in table.errors:
        report_error(error)
    if not table.saved:
        return 1
    print(f"replay saved to {table.saved}: python -m rllib_pommer.replay html {table.saved} "
          f"--out game.html")
    return 1 if table.errors else 0


if __name__ == "__main__":
    sys.exit(main())
