"""Bad input to the commands, as a careless user or a damaged disk gives it: each case ends in
exit code 2 and one line naming what was wrong (file, field, flag, value), never a traceback or
a silent success. (The HTTP server's 400s, policy files, curricula and checkpoints have their
own tables in tests/serving, tests/agents and tests/rl.)"""

from __future__ import annotations

import gzip
import json
import sys
import tracemalloc
from pathlib import Path

import pyarrow.parquet as pq
import pytest
import tomllib

from rllib_pommer import collect, imitate, ladder, replay, report, serve
from rllib_pommer.data.collector import Collection
from rllib_pommer.data.schema import SHARD_KEY
from rllib_pommer.game.records import write_games
from rllib_pommer.imitation import bc

from .conftest import PUBLIC_GAMES


@pytest.fixture(scope="module")
def record() -> dict:
    with gzip.open(PUBLIC_GAMES, "rt") as f:
        return json.loads(f.readline())


@pytest.fixture(scope="module")
def shards(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("shards")
    Collection(out, 2, 0, 1).run(workers=1)
    return out


def _record_file(tmp: Path, record: dict, change) -> Path:
    bad = json.loads(json.dumps(record))
    change(bad)
    path = tmp / "games.jsonl"
    write_games(path, [bad])
    return path


def _cut_gzip(tmp: Path, record: dict) -> Path:
    path = tmp / "games.jsonl.gz"
    write_games(path, [record])
    path.write_bytes(path.read_bytes()[:2000])
    return path


def _board_12x12(record: dict) -> None:
    for state in [record["initial_state"]] + [s["state"] for s in record["steps"]]:
        state["board"] = [row + [0] for row in state["board"]] + [[0] * 12]


def _empty(tmp: Path, record: dict) -> Path:
    path = tmp / "empty.jsonl"
    path.write_text("")
    return path


def _retagged_shards(tmp: Path, shards: Path, metadata: bytes) -> Path:
    """A copy of the shards whose first one carries other metadata under the shard key."""
    out = tmp / "retagged"
    out.mkdir()
    for shard in sorted(shards.iterdir()):
        table = pq.read_table(shard)
        if shard.name.endswith("000000.parquet"):
            table = table.replace_schema_metadata({**table.schema.metadata, SHARD_KEY: metadata})
        pq.write_table(table, out / shard.name)
    return out


def _json_file(tmp: Path, value) -> Path:
    path = tmp / "stats.json"
    path.write_text(json.dumps(value))
    return path


def _records(tmp: Path, lines: list[str], name: str = "static__vs__simple.jsonl") -> Path:
    """An arena records file of these lines."""
    path = tmp / name
    path.write_text("".join(line + "\n" for line in lines))
    return path


ROW = json.dumps({"game": 0, "seed": 0, "seats_a": [0, 2], "result": "win", "team": "static",
                  "vs": "simple", "filters": []})


def _with_summary(records: Path, text: str) -> Path:
    """`records` with an evaluate --json summary of this text beside it."""
    records.with_suffix(".json").write_text(text)
    return records


def _policy_folder(tmp: Path) -> Path:
    """A policy's folder with its weights and policy file, as shipped."""
    out = tmp / "shipped"
    out.mkdir()
    (out / "pi.pt").write_bytes(b"weights")
    bc.write_policy_file(out, "a shipped policy")
    return out


def _a_file(tmp: Path) -> Path:
    path = tmp / "a_file"
    path.write_text("")
    return path


def _cut_weights(tmp: Path) -> Path:
    import torch

    from rllib_pommer.imitation.network import PommerNet

    path = tmp / "pi.pt"
    torch.save(PommerNet().state_dict(), path)
    path.write_bytes(path.read_bytes()[:1000])
    return path


# (case, command, arguments made from (tmp folder, a reference record, tiny shards), message)
CASES = [
    ("truncated gzip replay", replay, lambda t, r, s: ["verify", str(_cut_gzip(t, r))],
     "games.jsonl.gz: damaged or cut short after"),
    ("record without initial_state", replay,
     lambda t, r, s: ["verify", str(_record_file(t, r, lambda g: g.pop("initial_state")))],
     "games.jsonl:1: missing field 'initial_state'"),
    ("step without state", replay,
     lambda t, r, s: ["verify", str(_record_file(t, r, lambda g: g["steps"][3].pop("state")))],
     "games.jsonl:1: steps[3]: missing field 'state'"),
    ("state without step_count", replay,
     lambda t, r, s: ["render", str(_record_file(
         t, r, lambda g: g["steps"][2]["state"].pop("step_count"))), "--out", str(t / "x.png")],
     "game 0, step 3: state: missing field 'step_count'"),
    ("unknown item code, render", replay,
     lambda t, r, s: ["render", str(_record_file(
         t, r, lambda g: g["steps"][4]["state"]["board"][0].__setitem__(0, 42))),
         "--out", str(t / "x.gif")],
     "game 0, step 5: state.board: unknown item code 42 at [0, 0]"),
    ("unknown item code, html", replay,
     lambda t, r, s: ["html", str(_record_file(
         t, r, lambda g: g["initial_state"]["board"][3].__setitem__(1, 99))),
         "--out", str(t / "x.html")],
     "game 0, step 0: state.board: unknown item code 99 at [3, 1]"),
    ("12x12 board", replay,
     lambda t, r, s: ["render", str(_record_file(t, r, _board_12x12)), "--out", str(t / "x.png")],
     "expected shape (11, 11), got (12, 12)"),
    ("--fps 0", replay,
     lambda t, r, s: ["render", str(_record_file(t, r, lambda g: None)), "--out",
                      str(t / "x.gif"), "--fps", "0"],
     "--fps: must be in (0, 100] steps per second, got 0"),
    ("empty replay file", replay, lambda t, r, s: ["verify", str(_empty(t, r))],
     "empty.jsonl: no game records: nothing to verify"),
    ("collect --out a file", collect,
     lambda t, r, s: ["--games", "1", "--out", str(_a_file(t)), "--workers", "1"],
     "a_file is a file, not a folder"),
    ("collect --out under a file", collect,
     lambda t, r, s: ["--games", "1", "--out", str(_a_file(t) / "data"), "--workers", "1"],
     "a_file is a file, not a folder"),
    ("collect --games 1e9", collect, lambda t, r, s: ["--games", "1e9", "--out", str(t)],
     "--games: must be a positive integer, got '1e9'"),
    ("shard metadata with other keys", imitate,
     lambda t, r, s: ["--data", str(_retagged_shards(t, s, b'{"seed": 0, "colour": "red"}')),
                      "--out", str(t / "p")],
     "shard-000000.parquet: malformed shard metadata"),
    ("shard metadata not JSON", imitate,
     lambda t, r, s: ["--data", str(_retagged_shards(t, s, b"{seed")), "--out", str(t / "p")],
     "shard-000000.parquet: malformed shard metadata"),
    ("imitate --batch-size 0", imitate,
     lambda t, r, s: ["--data", str(s), "--out", str(t / "p"), "--batch-size", "0"],
     "batch_size must be an integer >= 1, got 0"),
    ("imitate --threads 0", imitate,
     lambda t, r, s: ["--data", str(s), "--out", str(t / "p"), "--threads", "0"],
     "threads must be an integer >= 1, got 0"),
    ("imitate --checkpoint-every 0", imitate,
     lambda t, r, s: ["--data", str(s), "--out", str(t / "p"), "--checkpoint-every", "0"],
     "checkpoint_every must be an integer >= 1, got 0"),
    ("imitate --epochs 0", imitate,
     lambda t, r, s: ["--data", str(s), "--out", str(t / "p"), "--epochs", "0"],
     "epochs must be an integer >= 1, got 0"),
    ("imitate --val-fraction 1", imitate,
     lambda t, r, s: ["--data", str(s), "--out", str(t / "p"), "--val-fraction", "1"],
     "val_fraction must be in (0, 1), got 1.0"),
    ("imitate --val-fraction 0", imitate,
     lambda t, r, s: ["--data", str(s), "--out", str(t / "p"), "--val-fraction", "0"],
     "val_fraction must be in (0, 1), got 0.0"),
    ("imitate --val-fraction leaving no training games", imitate,
     lambda t, r, s: ["--data", str(s), "--out", str(t / "p"), "--val-fraction", "0.999999"],
     "val_fraction 0.999999 leaves no training games"),
    ("imitate --out under a file", imitate,
     lambda t, r, s: ["--data", str(s), "--out", str(_a_file(t) / "p")],
     "a_file is a file, not a folder"),
    # issue 40
    ("imitate --data a file", imitate,
     lambda t, r, s: ["--data", str(_a_file(t)), "--out", str(t / "p")],
     "a_file is a file, not a folder of shards"),
    ("replay agree --decisions a file of other statistics", replay,
     lambda t, r, s: ["agree", str(PUBLIC_GAMES), "--decisions",
                      str(_json_file(t, {"games": 5, "wins": 3}))],
     "stats.json: not a decisions file (it needs 'rows' and 'mean_agreement'"),
    ("replay agree --decisions with rows of another kind", replay,
     lambda t, r, s: ["agree", str(PUBLIC_GAMES), "--decisions",
                      str(_json_file(t, {"rows": [{"game": 1}], "mean_agreement": 0.5}))],
     "stats.json: rows[0] is not a decisions row"),
    ("report on records whose rows appear twice", report,
     lambda t, r, s: ["--out", str(t / "r"), str(_records(t, [ROW, ROW]))],
     "static__vs__simple.jsonl: game 0 (seed 0) of static vs simple appears twice"),
    ("report on a records file given twice", report,
     lambda t, r, s: ["--out", str(t / "r"), str(_records(t, [ROW])),
                      str(_records(t, [ROW], "copy.jsonl"))],
     "copy.jsonl: game 0 (seed 0) of static vs simple appears twice (also in"),
    ("report on a damaged summary beside the records", report,
     lambda t, r, s: ["--out", str(t / "r"), str(_with_summary(_records(t, [ROW]),
                                                               '{"team": "st'))],
     "static__vs__simple.json:1: not an evaluate --json summary"),
    ("imitate --out over a policy it did not train", imitate,
     lambda t, r, s: ["--data", str(s), "--out", str(_policy_folder(t))],
     "shipped/pi.pt exists (a policy not trained here); pass --force to replace it"),
    ("report on a damaged records line", report,
     lambda t, r, s: ["--out", str(t / "r"), str(_records(t, [ROW, ROW[:30]]))],
     "static__vs__simple.jsonl:2: not JSON"),
    ("serve --port 70000", serve, lambda t, r, s: ["--policy", "static", "--port", "70000"],
     "--port must be in 0..65535, got 70000"),
    ("ladder unknown policy", ladder,
     lambda t, r, s: ["--policies", "static,nosuch", "--out", str(t / "l")],
     "unknown policy 'nosuch'"),
    ("ladder --games 0", ladder,
     lambda t, r, s: ["--policies", "static,simple", "--games", "0", "--out", str(t / "l")],
     "games a pair must be a positive number, got 0"),
    ("ladder --games abc", ladder,
     lambda t, r, s: ["--policies", "static,simple", "--games", "abc", "--out", str(t / "l")],
     "argument --games: invalid int value: 'abc'"),
    ("ladder --bootstrap 0", ladder,
     lambda t, r, s: ["--policies", "static,simple", "--bootstrap", "0", "--out", str(t / "l")],
     "bootstrap replicates must be at least 1, got 0"),
    ("ladder of one policy", ladder,
     lambda t, r, s: ["--policies", "static,static", "--out", str(t / "l")],
     "a ladder needs at least two policies, got ['static', 'static']"),
    ("ladder policy by path", ladder,
     lambda t, r, s: ["--policies", "static,policies/simple.toml", "--out", str(t / "l")],
     "not paths: got 'policies/simple.toml'"),
    ("ladder --out a file", ladder,
     lambda t, r, s: ["--policies", "static,simple", "--out", str(_a_file(t))],
     "a_file is a file, not a folder"),
    # issue 50
    ("ladder --policies naming none", ladder,
     lambda t, r, s: ["--policies", "", "--out", str(t / "l")],
     "argument --policies: names no policy (got ''); leave --policies out for the default"),
    ("ladder --games odd", ladder,
     lambda t, r, s: ["--policies", "static,simple", "--games", "3", "--out", str(t / "l")],
     "games a pair must be even, so that each policy plays half of them on seats {0, 2}"),
    ("ladder --workers -1", ladder,
     lambda t, r, s: ["--policies", "static,simple", "--workers", "-1", "--out", str(t / "l")],
     "argument --workers: must be a positive integer, got '-1'"),
    ("ladder --seed -1", ladder,
     lambda t, r, s: ["--policies", "static,simple", "--seed", "-1", "--out", str(t / "l")],
     "argument --seed: must be a non-negative integer, got '-1'"),
]


@pytest.mark.parametrize("command, make_args, message",
                         [pytest.param(*case[1:], id=case[0]) for case in CASES])
def test_bad_input_is_one_line_and_exit_2(command, make_args, message, tmp_path, record, shards,
                                          capsys):
    try:
        code = command.main(make_args(tmp_path, record, shards))
    except SystemExit as exc:  # argparse refuses bad values itself, also with exit code 2
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2, err
    assert message in err
    error_lines = [line for line in err.splitlines() if "error:" in line]
    assert len(error_lines) == 1 and message in error_lines[0], err
    assert "Traceback" not in err


def test_a_cut_short_pi_weights_file_is_refused_before_ray_leaving_no_run_folder(tmp_path):
    """Before, the run died deep inside a Ray actor and its half-made run folder then blocked
    the same --out."""
    import subprocess

    out = tmp_path / "run"
    done = subprocess.run([sys.executable, "-m", "rllib_pommer.train", "--curriculum", "smoke",
                           "--out", str(out), "--pi-weights", str(_cut_weights(tmp_path))],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert "pi.pt: not a readable weights file" in done.stderr
    assert "Traceback" not in done.stderr and not out.exists()


def test_policy_files_for_names_with_quotes_stay_valid_toml(tmp_path):
    out = tmp_path / "policies" / 'clone "b\\2" \U0001f600\t'
    out.parent.mkdir()
    data_names = 'data "v2" \\ tab\t é'
    policy = bc.write_policy_file(out, f"Behaviour cloning of SimpleAgent ({data_names})")
    written = tomllib.loads(policy.read_text(encoding="utf-8"))
    assert written["weights"] == f"{out.name}/pi.pt"
    assert written["description"] == f"Behaviour cloning of SimpleAgent ({data_names})"


def test_planning_a_billion_games_costs_nothing_up_front(tmp_path):
    """Shards are planned on demand: asking for 10^9 games holds no list of them."""
    tracemalloc.start()
    try:
        collection = Collection(tmp_path / "huge", 10**9, 0)
        first = next(collection._missing())
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert first == 0 and len(collection.plan) == -(-10**9 // collection.plan.template.shard_games)
    assert peak < 1_000_000
