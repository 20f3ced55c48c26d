"""The project as a user installs it: a wheel (not editable) in a fresh venv, used from elsewhere.

    python benchmarks/wheel_check.py [--venv DIR] [--keep]

Creates a venv (`--venv DIR`, default a temporary folder), installs the pinned CPU torch and this
repository with `pip install torch==2.13.0 REPO` (pip builds a wheel; setup.py puts `policies/`
and `curriculum/` inside it), then, from an empty folder outside the repository, runs

1. `python -m rllib_pommer.evaluate --team imitation --vs simple --games 4` (a shipped learned
   policy by name; the first run compiles the kernels and says so),
2. `pommer-train --curriculum smoke --out DIR` (a shipped curriculum by name, the console script),
3. `pommer-evaluate --team DIR --vs static --games 2` (the trained run, by path),

and checks each one's exit code and output, printing the time each step took. Exit code 0 when
all pass, 1 otherwise. A `--venv` that already exists is reused: only this project is
reinstalled (`--no-deps --force-reinstall`), which takes seconds instead of the minutes a full
install of Ray and torch takes. The venv is deleted at the end unless `--venv` or `--keep` is
given. CI runs it (.ci/run; about 6 minutes, most of it installing Ray and torch); run it
after changing what the package ships (pyproject.toml, setup.py, rllib_pommer/util/shipped.py).
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TORCH = "torch==2.13.0"


def run(what: str, command: list[str], cwd: Path, expect: str, timeout: float) -> bool:
    start = time.monotonic()
    done = subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    seconds = time.monotonic() - start
    ok = done.returncode == 0 and expect in done.stdout
    print(f"{'ok  ' if ok else 'FAIL'} {what}: {seconds:.0f} s", flush=True)
    if not ok:
        print(f"  exit {done.returncode}; wanted {expect!r} in the output\n"
              f"  stdout: {done.stdout[-1500:]}\n  stderr: {done.stderr[-3000:]}")
    return ok


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--venv", type=Path, help="venv folder (reused if it exists)")
    parser.add_argument("--keep", action="store_true", help="keep a temporary venv")
    args = parser.parse_args(argv)
    scratch = Path(tempfile.mkdtemp(prefix="wheel_check_"))
    venv = args.venv.resolve() if args.venv else scratch / "venv"
    python, bin_dir = venv / "bin" / "python", venv / "bin"
    try:
        if python.is_file():
            install = [str(python), "-m", "pip", "install", "-q", "--no-deps",
                       "--force-reinstall", str(REPO)]
        else:
            subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
            install = [str(python), "-m", "pip", "install", "-q", TORCH, str(REPO)]
        elsewhere = scratch / "elsewhere"
        elsewhere.mkdir()
        run_dir = elsewhere / "smoke_run"
        checks = [
            ("pip install (non-editable)", install, "", 3600),
            ("evaluate a shipped policy by name",
             [str(python), "-m", "rllib_pommer.evaluate", "--team", "imitation", "--vs",
              "simple", "--games", "4"], "imitation vs simple: 4 games", 1800),
            ("pommer-train a shipped curriculum by name",
             [str(bin_dir / "pommer-train"), "--curriculum", "smoke", "--out", str(run_dir)],
             "done:", 1800),
            ("pommer-evaluate the trained run by path",
             [str(bin_dir / "pommer-evaluate"), "--team", str(run_dir), "--vs", "static",
              "--games", "2"], "vs static: 2 games", 900),
        ]
        for what, command, expect, timeout in checks:
            if not run(what, command, elsewhere, expect, timeout):
                return 1
        shipped = subprocess.run([str(python), "-c",
                                  "from rllib_pommer.util.shipped import data_dir;"
                                  "print(data_dir('policies'))"], cwd=elsewhere,
                                 capture_output=True, text=True, check=True).stdout.strip()
        inside = Path(shipped).is_relative_to(venv)
        print(f"{'ok  ' if inside else 'FAIL'} policies read from the installed package: "
              f"{shipped}")
        return 0 if inside else 1
    finally:
        keep_scratch = args.keep and args.venv is None  # the temporary venv lives in it
        shutil.rmtree(scratch / "elsewhere" if keep_scratch else scratch, ignore_errors=True)
        if args.keep or args.venv:
            print(f"venv kept: {venv}")


if __name__ == "__main__":
    sys.exit(main())
