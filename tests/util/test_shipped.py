"""Named policies and curricula resolve from any working directory, in a clone and in a wheel's
layout; user files by path stay relative to where the command runs. (The whole wheel, installed
into a fresh venv: benchmarks/wheel_check.py.)"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from rllib_pommer.agents.registry import resolve_policy
from rllib_pommer.curriculum.curriculum import find_curriculum, load_curriculum
from rllib_pommer.util import shipped

REPO = Path(__file__).resolve().parents[2]


def test_a_variable_then_the_wheels_copy_then_the_repositorys_folder(tmp_path, monkeypatch):
    package = tmp_path / "site" / "rllib_pommer"
    (package / "_shipped" / "policies").mkdir(parents=True)
    monkeypatch.setattr(shipped, "PACKAGE", package)
    monkeypatch.delenv("RLLIB_POMMER_POLICIES", raising=False)
    monkeypatch.delenv("RLLIB_POMMER_CURRICULA", raising=False)
    assert shipped.data_dir("policies") == package / "_shipped" / "policies"  # a wheel
    assert shipped.data_dir("curriculum") == tmp_path / "site" / "curriculum"  # a clone
    monkeypatch.setenv("RLLIB_POMMER_POLICIES", str(tmp_path / "mine"))
    assert shipped.data_dir("policies") == tmp_path / "mine"


def test_names_resolve_from_any_directory_and_paths_from_the_working_one(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # far from the repository
    assert resolve_policy("simple_action").path == REPO / "policies" / "simple.toml"
    assert find_curriculum("smoke") == REPO / "curriculum" / "smoke.toml"
    assert load_curriculum("quick").pi_weights == REPO / "policies" / "imitation" / "pi.pt"
    assert load_curriculum("paper").pi_weights == REPO / "policies" / "imitation_v2" / "pi.pt"
    (tmp_path / "mine.toml").write_text(
        '[[stage]]\nname = "a"\nopponent = "static"\nepisodes = 5\n')
    (tmp_path / "policies").mkdir()
    (tmp_path / "policies" / "calm.toml").write_text('kind = "static"\n')
    assert find_curriculum("mine.toml") == tmp_path / "mine.toml"
    assert resolve_policy("policies/calm.toml").path == Path("policies/calm.toml")
    with pytest.raises(ValueError, match=r"valid names: \[.*'smoke'"):
        find_curriculum("calm")


def test_a_built_wheel_carries_the_data_folders_and_finds_them(tmp_path):
    """setup.py's build step, as `pip install .` runs it: policies/ and curriculum/ land inside
    the package, and the installed code reads them there, from any directory."""
    built = tmp_path / "lib"
    subprocess.run([sys.executable, "setup.py", "-q", "build_py", "--build-lib", str(built)],
                   cwd=REPO, check=True, capture_output=True)
    inside = built / "rllib_pommer" / "_shipped"
    for name in ("policies/imitation/pi.pt", "policies/simple.toml", "curriculum/paper.toml"):
        assert (inside / name).is_file(), name
    assert not list(inside.rglob("training"))  # local training output stays out
    where = subprocess.run(
        [sys.executable, "-I", "-c", "import sys; sys.path.insert(0, sys.argv[1]); "
         "from rllib_pommer.util.shipped import data_dir; "
         "print(data_dir('policies'), data_dir('curriculum'))", str(built)],
        cwd=tmp_path, check=True, capture_output=True, text=True).stdout.split()
    assert where == [str(inside / "policies"), str(inside / "curriculum")]
