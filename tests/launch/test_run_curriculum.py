"""A run remembers its curriculum (a shipped name, or the file a user gave): `--resume` trains on
it with or without `--curriculum`, refuses another naming both, and a curriculum file that is
gone is named (issue 40, cases 3 and 4). Ray never starts here: `train` is replaced by a stand-in
that notes what it was given."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path
from types import SimpleNamespace

import pytest

from rllib_pommer.curriculum.curriculum import (
    PI_START_KEY,
    RUN_CURRICULUM_FILE,
    curriculum_dir,
    load_curriculum,
)
from rllib_pommer.launch import training
from rllib_pommer.train import main as train_main


def main(argv: list[str]) -> int:
    """`train`'s exit code, also where argparse exits (a usage error: 2)."""
    try:
        return train_main(argv)
    except SystemExit as exc:
        return exc.code


@pytest.fixture
def trained(monkeypatch):
    """Ray, Tune's restore check and the training replaced: the curricula `train` was handed."""
    import ray

    handed = []

    def train(curriculum, out, settings, start=None):
        handed.append(curriculum)
        return SimpleNamespace(checkpoint=None, path=str(out),
                               metrics={"curriculum": {"episodes": curriculum.total_episodes}})

    monkeypatch.setattr(training, "train", train)
    monkeypatch.setattr(training, "init_ray", lambda *args, **kwargs: None)
    monkeypatch.setattr(training.ray_session, "record", lambda out: None)
    monkeypatch.setattr(training, "pack_run", lambda out: None)
    monkeypatch.setattr(ray, "shutdown", lambda: None)
    return handed


def _started(run: Path) -> None:
    """What makes a folder a run to resume: a trial folder (Tune's params.json in it)."""
    params = run / "PPO_pommerman_team_00000" / "params.json"
    params.parent.mkdir(parents=True, exist_ok=True)
    if not params.is_file():
        params.write_text("{}")


def _params_run(run: Path, name: str, path: str) -> None:
    """A run started before runs noted their curriculum: only its trial's params.json names it."""
    trial = run / "PPO_pommerman_team_00000"
    trial.mkdir(parents=True)
    (trial / "params.json").write_text(json.dumps(
        {"callbacks": "functools.partial(<class 'rllib_pommer.rl.callbacks.CurriculumCallback'>"
                      f", Curriculum(name='{name}', path=PosixPath('{path}'), stages=())"}))
    _started(run)


def test_a_new_run_notes_its_curriculum_and_a_resume_without_curriculum_uses_it(
        tmp_path, trained, capsys):
    run = tmp_path / "run"
    assert main(["--curriculum", "smoke", "--out", str(run)]) == 0
    start = hashlib.sha256(load_curriculum("smoke").pi_weights.read_bytes()).hexdigest()
    noted = {"curriculum": "smoke", "name": "smoke", PI_START_KEY: start}
    assert json.loads((run / RUN_CURRICULUM_FILE).read_text()) == noted
    _started(run)
    assert main(["--out", str(run), "--resume"]) == 0  # the README's command, no --curriculum
    assert json.loads((run / RUN_CURRICULUM_FILE).read_text()) == noted  # the start stays
    assert [c.name for c in trained] == ["smoke", "smoke"]
    assert f"done: {run}" in capsys.readouterr().out


@pytest.mark.parametrize("state", ["stopped", "finished"])
def test_an_older_run_resumes_its_own_curriculum_and_refuses_another_by_name(
        tmp_path, trained, capsys, state):
    """The run noted nothing; its params.json names smoke in another clone's curriculum folder.
    Without --curriculum the default (quick) was trained on before; now smoke is."""
    run = tmp_path / state
    _params_run(run, "smoke", "/elsewhere/clone/curriculum/smoke.toml")
    if state == "finished":
        (run / "PPO_pommerman_team_00000" / "result.json").write_text(json.dumps(
            {"curriculum": {"episodes": 24}}) + "\n")
    assert main(["--out", str(run), "--resume", "--curriculum", "quick"]) == 2
    err = capsys.readouterr().err
    assert (f"--resume: the run in {run} trains on curriculum 'smoke', not 'quick'; resume it "
            f"without --curriculum") in err
    assert trained == []
    assert main(["--out", str(run), "--resume"]) == 0
    assert main(["--out", str(run), "--resume", "--curriculum", "smoke"]) == 0
    assert [c.path for c in trained] == [curriculum_dir().resolve() / "smoke.toml"] * 2
    assert json.loads((run / RUN_CURRICULUM_FILE).read_text())["curriculum"] == "smoke"


def test_a_curriculum_file_is_remembered_by_its_path_whatever_name_it_takes(
        tmp_path, trained, capsys):
    """A file reusing a shipped name (name = "quick") is not the shipped quick."""
    mine = tmp_path / "mine" / "mysmoke.toml"
    mine.parent.mkdir()
    mine.write_text((curriculum_dir() / "smoke.toml").read_text()
                    .replace('name = "smoke"', 'name = "quick"'))
    run = tmp_path / "run"
    assert main(["--curriculum", str(mine), "--out", str(run)]) == 0
    noted = json.loads((run / RUN_CURRICULUM_FILE).read_text())
    assert (noted["curriculum"], noted["name"]) == (str(mine.resolve()), "quick")
    _started(run)
    assert main(["--out", str(run), "--resume", "--curriculum", "quick"]) == 2
    assert (f"trains on curriculum 'quick' ({mine.resolve()}), not 'quick'"
            in capsys.readouterr().err)
    assert main(["--out", str(run), "--resume"]) == 0
    assert [c.path for c in trained] == [mine.resolve()] * 2
    assert trained[-1].total_episodes == 24  # smoke's stages, not quick's

    moved = tmp_path / "moved.toml"
    shutil.move(mine, moved)
    assert main(["--out", str(run), "--resume"]) == 2
    assert (f"trained on the curriculum file {mine.resolve()} (noted in "
            f"{run / RUN_CURRICULUM_FILE}), which is gone" in capsys.readouterr().err)
    assert main(["--out", str(run), "--resume", "--curriculum", str(moved)]) == 0
    assert trained[-1].path == moved.resolve()
