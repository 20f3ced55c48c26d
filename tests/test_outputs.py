"""Outputs a user names are never lost: every command that writes a file the user named refuses
an existing one unless given `--force`, refuses a name of another kind of file, and no two
outputs of one command may name the same file. The refusals come before any work, as one line
naming the option and the file, exit 2."""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path

import pytest

import rllib_pommer
from rllib_pommer import evaluate, play, replay
from rllib_pommer.util.outputs import check_distinct, check_output

from .conftest import PUBLIC_GAMES

# Every job, by what it writes. FILE_OUTPUTS: (command, arguments before the output, the
# output's option, a file name it takes); each refuses that file when it exists.
FILE_OUTPUTS = [
    (evaluate, ["--team", "static", "--vs", "static", "--games", "2", "--workers", "1"],
     "--records", "rows.jsonl.gz"),
    (evaluate, ["--team", "static", "--vs", "static", "--games", "2", "--workers", "1",
                "--record", "1"], "--replays", "games.jsonl"),
    (play, ["--team", "static", "--vs", "static", "--port", "0"], "--out", "mine.jsonl.gz"),
    (replay, ["render", str(PUBLIC_GAMES)], "--out", "game.gif"),
    (replay, ["html", str(PUBLIC_GAMES)], "--out", "game.html"),
]
IDS = [f"{command.__name__.rsplit('.', 1)[1]} {flag}" for command, _, flag, _ in FILE_OUTPUTS]
# Folders a job owns and resumes or redraws in place (their docs say so), outputs whose
# existing files their job refuses itself (train --export), and jobs that write no file.
OTHER_JOBS = {
    "collect": "resumes its dataset folder",
    "imitate": "resumes its policy folder; a policy it did not train only with --force",
    "train": "resumes its run folder; --export refuses existing weights and policy files",
    "ladder": "resumes its folder: records of pairs already played are kept",
    "report": "redraws its report folder",
    "bench": "prints",
    "serve": "answers HTTP",
}


def _exit_code(command, argv: list[str]) -> int:
    try:
        return command.main(argv)
    except SystemExit as exc:  # argparse refuses bad values itself, also with exit code 2
        return exc.code


def _one_error(err: str, message: str) -> None:
    lines = [line for line in err.splitlines() if "error:" in line]
    assert len(lines) == 1 and message in lines[0] and "Traceback" not in err, err


def test_every_job_is_listed_by_what_it_writes():
    jobs = {info.name for info in pkgutil.iter_modules(rllib_pommer.__path__)
            if not info.ispkg and hasattr(importlib.import_module(f"rllib_pommer.{info.name}"),
                                          "main")}
    listed = {command.__name__.rsplit(".", 1)[1] for command, *_ in FILE_OUTPUTS}
    assert jobs == listed | set(OTHER_JOBS)


@pytest.mark.parametrize("command, argv, flag, name", FILE_OUTPUTS, ids=IDS)
def test_an_existing_output_file_is_kept_unless_forced(command, argv, flag, name, tmp_path,
                                                       capsys):
    path = tmp_path / name
    path.write_bytes(b"the user's own file")
    assert _exit_code(command, [*argv, flag, str(path)]) == 2
    _one_error(capsys.readouterr().err, f"{flag} {path} exists; pass --force to replace it")
    assert path.read_bytes() == b"the user's own file"


@pytest.mark.parametrize("command, argv, flag, name",
                         [case for case in FILE_OUTPUTS if case[0] is not play],
                         ids=[i for i in IDS if not i.startswith("play")])
def test_force_replaces_an_existing_output_file(command, argv, flag, name, tmp_path):
    path = tmp_path / name
    path.write_bytes(b"the user's own file")
    assert _exit_code(command, [*argv, flag, str(path), "--force"]) == 0
    assert path.read_bytes() != b"the user's own file" and path.stat().st_size > 0


def test_play_with_force_gets_past_the_existing_file(tmp_path, monkeypatch, capsys):
    """The check passes; the game itself is not served here (an unknown policy stops it)."""
    path = tmp_path / "mine.jsonl.gz"
    path.write_bytes(b"kept")
    argv = ["--team", "static", "--vs", "nosuch", "--port", "0", "--out", str(path)]
    assert play.main([*argv, "--force"]) == 2
    _one_error(capsys.readouterr().err, "unknown policy 'nosuch'")


@pytest.mark.parametrize("spelling", ["same.jsonl.gz", "./sub/../same.jsonl.gz"])
def test_two_outputs_of_one_command_may_not_share_a_file(spelling, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    argv = ["--team", "static", "--vs", "static", "--games", "2", "--records", "same.jsonl.gz",
            "--record", "2", "--replays", spelling, "--force"]
    assert _exit_code(evaluate, argv) == 2
    _one_error(capsys.readouterr().err,
               f"--records same.jsonl.gz and --replays {Path(spelling)} are one file")
    assert not (tmp_path / "same.jsonl.gz").exists()


@pytest.mark.parametrize("flag, name, kinds", [
    ("--records", "policy.toml", ".jsonl or .jsonl.gz or .csv"),
    ("--replays", "games.csv", ".jsonl or .jsonl.gz"),
])
def test_an_output_of_another_kind_is_refused_even_forced(flag, name, kinds, tmp_path, capsys):
    path = tmp_path / name
    path.write_text('kind = "static"\n')
    argv = ["--team", str(path) if name.endswith(".toml") else "static", "--vs", "static",
            "--games", "2", "--record", "1", flag, str(path), "--force"]
    assert _exit_code(evaluate, argv) == 2
    _one_error(capsys.readouterr().err, f"{flag} {path}: the name must end in {kinds}")
    assert path.read_text() == 'kind = "static"\n'


def test_play_refuses_a_replay_name_of_another_kind(tmp_path, capsys):
    out = tmp_path / "game.txt"
    assert play.main(["--team", "static", "--vs", "static", "--out", str(out)]) == 2
    _one_error(capsys.readouterr().err, f"--out {out}: the name must end in .jsonl or .jsonl.gz")


def test_check_output_and_check_distinct(tmp_path):
    existing = tmp_path / "a.jsonl"
    existing.write_text("")
    check_output(existing, "--x", force=True, suffixes=(".jsonl",))
    check_output(tmp_path / "b.JSONL", "--x", suffixes=(".jsonl",))  # the kind in any case
    with pytest.raises(ValueError, match="--x .*a.jsonl exists"):
        check_output(existing, "--x")
    check_distinct({"--a": tmp_path / "a.jsonl", "--b": tmp_path / "b.jsonl", "--c": None})
    with pytest.raises(ValueError, match="--a .*a.jsonl and --b .*a.jsonl are one file"):
        check_distinct({"--a": tmp_path / "a.jsonl", "--b": tmp_path / "x" / ".." / "a.jsonl"})


def test_an_output_that_is_a_link_to_the_other_is_the_same_file(tmp_path):
    target = tmp_path / "a.jsonl"
    target.write_text("")
    link = tmp_path / "link.jsonl"
    link.symlink_to(target)
    with pytest.raises(ValueError, match="are one file"):
        check_distinct({"--a": Path(target), "--b": link})
