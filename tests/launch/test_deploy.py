"""The cluster configs in deploy/ hold what a run on them needs. Ray's own launcher prepares and
validates deploy/cluster.yaml as `ray up` does; in it and in the KubeRay manifest
deploy/kuberay.yaml, every node installs this project with the torch CI tests, runs Ray from the
environment it installed into, at the Ray version and on a Python pyproject.toml allows, with
token authentication and the runs' storage at one path on every node; the head and the workers
offer Ray the resources docs/scaling.md says they do."""

from __future__ import annotations

import argparse
import copy
import re
import shlex
from pathlib import Path

import pytest
import ray
import tomllib
import yaml
from packaging.requirements import Requirement
from packaging.specifiers import SpecifierSet

from rllib_pommer.curriculum.settings import RunSettings
from rllib_pommer.train import main as train_main
from rllib_pommer.util.cli_options import add_options, settings_from

REPO = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
CI_TORCH = re.search(r"torch==([\w.+]+)", (REPO / ".ci" / "run").read_text()).group(1)
SCALING = (REPO / "docs" / "scaling.md").read_text()


def _ray_pin() -> SpecifierSet:
    (ray_req,) = [Requirement(dep) for dep in PYPROJECT["dependencies"]
                  if Requirement(dep).name == "ray"]
    assert "rllib" in ray_req.extras
    return ray_req.specifier


@pytest.fixture(scope="module")
def launcher() -> dict:
    return yaml.safe_load((REPO / "deploy" / "cluster.yaml").read_text())


@pytest.fixture(scope="module")
def kuberay() -> tuple[dict, dict]:
    claim, cluster = yaml.safe_load_all((REPO / "deploy" / "kuberay.yaml").read_text())
    return claim, cluster


def test_ray_up_takes_the_launcher_config(launcher):
    from ray.autoscaler._private.util import prepare_config, validate_config

    prepared = prepare_config(copy.deepcopy(launcher))  # what `ray up` does first
    validate_config(prepared)  # Ray's schema for cluster configs
    assert prepared["provider"]["type"] == "local"
    assert len(launcher["provider"]["worker_ips"]) == prepared["max_workers"] == 2


def test_every_launched_node_installs_the_checkout_and_runs_ray_from_it(launcher):
    # This checkout goes to every node, without a local environment or runs.
    assert launcher["file_mounts"]["~/rllib-pommer"] == "."
    assert {".venv", "runs", "campaign"} <= set(launcher["rsync_exclude"])
    venv = "~/pommer-venv"
    assert launcher["setup_commands"] == [
        f"python3 -m venv {venv}", f"{venv}/bin/pip install -q torch=={CI_TORCH} -e ~/rllib-pommer"]
    head, worker = launcher["head_start_ray_commands"], launcher["worker_start_ray_commands"]
    for commands in (head, worker):
        assert all(f"RAY_AUTH_MODE=token {venv}/bin/ray " in command for command in commands)
        assert commands[0].endswith("ray stop") and "ray start" in commands[1]
    # The token every node and the driver share, where Ray reads it by default.
    assert launcher["file_mounts"]["~/.ray/auth_token"] == "~/.ray/auth_token"
    # The workers join the head at the port it listens on; each offers what Ray detects.
    port = re.search(r"--head --port=(\d+)", head[1]).group(1)
    assert f"--address=$RAY_HEAD_IP:{port}" in worker[1]
    assert "--num-cpus" not in " ".join(head + worker)


def test_the_kuberay_cluster_runs_the_pinned_ray_on_an_allowed_python(kuberay):
    claim, cluster = kuberay
    assert (claim["kind"], cluster["apiVersion"], cluster["kind"]) == (
        "PersistentVolumeClaim", "ray.io/v1", "RayCluster")
    version = cluster["spec"]["rayVersion"]
    assert version == ray.__version__ and version in _ray_pin()
    containers = _containers(cluster)
    pythons = set()
    for group, container in containers:
        image = re.fullmatch(r"rayproject/ray:(?P<ray>[\d.]+)-py(?P<py>\d)(?P<minor>\d+)-"
                             r"(?P<kind>cpu|gpu)", container["image"])
        assert image and image["ray"] == version, container["image"]
        pythons.add(f"{image['py']}.{image['minor']}")
        gpus = container["resources"]["limits"].get("nvidia.com/gpu")
        assert (image["kind"] == "gpu") == bool(gpus), group
    (python,) = pythons
    assert python in SpecifierSet(PYPROJECT["requires-python"])


def test_every_kuberay_pod_installs_the_project_then_starts_ray(kuberay):
    _, cluster = kuberay
    assert cluster["metadata"]["annotations"]["ray.io/overwrite-container-cmd"] == "true"
    for group, container in _containers(cluster):
        assert container["command"] == ["/bin/bash", "-lc", "--"], group
        (script,) = container["args"]
        install, start = script.split("&&")
        assert f'pip install --no-cache-dir "torch=={CI_TORCH}" "$RLLIB_POMMER_PIP"' in install
        assert start.strip() == "$KUBERAY_GEN_RAY_START_CMD"
        env = {item["name"]: item for item in container["env"]}
        assert Requirement(env["RLLIB_POMMER_PIP"]["value"]).name == PYPROJECT["name"]
        assert env["RAY_AUTH_MODE"]["value"] == "token"
        assert env["RAY_AUTH_TOKEN"]["valueFrom"]["secretKeyRef"]["key"] == "auth_token"


def test_kuberay_offers_ray_what_the_pods_hold(kuberay):
    """KubeRay gives Ray each pod's limits: requests equal to them keep that true on a busy
    node; the head, which holds the GCS and the driver, offers no CPUs."""
    _, cluster = kuberay
    spec = cluster["spec"]
    assert spec["headGroupSpec"]["rayStartParams"] == {"num-cpus": "0"}
    for group in spec["workerGroupSpecs"]:
        assert group["rayStartParams"] == {}, group["groupName"]
        assert group["minReplicas"] <= group["replicas"] <= group["maxReplicas"]
    for group, container in _containers(cluster):
        assert container["resources"]["requests"] == container["resources"]["limits"], group


def test_runs_live_on_storage_every_node_shares(kuberay):
    """One volume that every pod mounts at one path, and the cluster commands of
    docs/scaling.md write their runs under it."""
    claim, cluster = kuberay
    assert claim["spec"]["accessModes"] == ["ReadWriteMany"]
    mounts = set()
    for template in _templates(cluster):
        (volume,) = template["spec"]["volumes"]
        assert volume["persistentVolumeClaim"]["claimName"] == claim["metadata"]["name"]
        for container in template["spec"]["containers"]:
            (mount,) = container["volumeMounts"]
            assert mount["name"] == volume["name"]
            mounts.add(mount["mountPath"])
    (path,) = mounts
    cluster_runs = re.findall(r"--address auto[^\n]*--out (\S+)", SCALING)
    assert cluster_runs and all(out.startswith(path + "/") for out in cluster_runs)


def _templates(cluster: dict) -> list[dict]:
    spec = cluster["spec"]
    return [spec["headGroupSpec"]["template"],
            *(group["template"] for group in spec["workerGroupSpecs"])]


def _containers(cluster: dict) -> list[tuple[str, dict]]:
    spec = cluster["spec"]
    groups = [("head", spec["headGroupSpec"]),
              *((group["groupName"], group) for group in spec["workerGroupSpecs"])]
    return [(name, container) for name, group in groups
            for container in group["template"]["spec"]["containers"]]


def test_the_page_commands_are_runs_train_accepts(capsys):
    """Each `python -m rllib_pommer.train` command of docs/scaling.md parses with train's options
    and, where it starts a run, makes settings that pass RunSettings' checks (the layouts fit
    the CPUs they name)."""
    parser = argparse.ArgumentParser(exit_on_error=False)
    add_options(parser, RunSettings, {})
    for flag in ("--stop", "--pack"):
        parser.add_argument(flag, action="store_true")
    parser.add_argument("--export")
    with pytest.raises(SystemExit):
        train_main(["--help"])
    usage = capsys.readouterr().out.split("\n\n")[0]  # the usage lines list every option
    offered = set(re.findall(r"(--[a-z][a-z-]*)", usage)) - {"--help"}
    assert offered == {option for action in parser._actions for option in action.option_strings
                       if option.startswith("--") and option != "--help"}
    commands = re.findall(r"-m rllib_pommer\.train (.*)$", SCALING, flags=re.MULTILINE)
    assert len(commands) >= 8
    for command in commands:
        args = parser.parse_args(shlex.split(command))
        if not (args.stop or args.pack):
            settings_from(RunSettings, args)
