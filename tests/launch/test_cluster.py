"""`train --address` on a Ray cluster of five nodes on this machine: Ray's own test utility
(`ray.cluster_utils.Cluster`, run by tests/launch/ray_cluster.py) starts a head and four worker
nodes of one logical CPU each, every node with a custom resource that names it. Runs the cluster
cannot hold are refused up front, in one line: more CPUs than the five nodes have together, and
a learner bigger than any one node. A run with two learner actors and two remote env runners
trains on the cluster with each of its five actors on a node of its own, stops at a checkpoint
with `train --stop`, and, once the cluster is gone with every process of its session, resumes
from its data on a Ray instance of its own, with neither learner actors nor runners."""

from __future__ import annotations

import contextlib
import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

import pytest
import ray

from rllib_pommer.curriculum.settings import RunSettings
from rllib_pommer.launch import ray_session
from rllib_pommer.launch.training import check_learner_fits_a_node
from rllib_pommer.runs.checkpoints import checkpoint_complete, checkpoint_iteration
from rllib_pommer.runs.history import legs

REPO = Path(__file__).resolve().parents[2]
HELPER = Path(__file__).with_name("ray_cluster.py")
# One logical CPU per node, so that the run's five actors (the algorithm's, two learners, two
# env runners) can only be placed one to a node.
NODE_NAMES = ["head", "worker_a", "worker_b", "worker_c", "worker_d"]
NODES = [{"CPU": 1, name: 1} for name in NODE_NAMES]
START_S = 400.0  # for the cluster to come up, on a loaded machine too
RUN_S = 400.0  # for a training command to reach what the test waits for
RUNNER = "MultiAgentEnvRunner"
LEARNER = "create_executable_class.<locals>._WrappedExecutable"  # RLlib's, in Ray Train's wrapper


class RayCluster:
    """The cluster of `ray_cluster.py` in a child process, for a `with` block: its address,
    session folder and nodes; `actors()` while it is up; `stop()` (or the block's end) takes
    it down and returns the pids of its session still running."""

    def __init__(self, nodes: list[dict], log: Path):
        self._nodes, self._log = nodes, log
        self._replies: queue.Queue = queue.Queue()
        self.left: list[int] | None = None

    def __enter__(self) -> RayCluster:
        with open(self._log, "w") as log:
            self._process = subprocess.Popen(
                [sys.executable, str(HELPER), json.dumps(self._nodes)], cwd=REPO,
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=log, text=True)
        threading.Thread(target=self._read, daemon=True).start()
        try:
            started = self._reply(START_S, "the cluster to start")
        except BaseException:
            self._end()
            raise
        self.address, self.session_dir = started["address"], started["session_dir"]
        self.nodes = started["nodes"]
        return self

    def _read(self) -> None:
        for line in self._process.stdout:
            if line.startswith("CLUSTER "):
                self._replies.put(json.loads(line.removeprefix("CLUSTER ")))
        self._replies.put(None)  # the helper has exited

    def _reply(self, timeout: float, what: str):
        try:
            reply = self._replies.get(timeout=timeout)
        except queue.Empty:
            raise AssertionError(f"timed out waiting for {what}; {self._tail()}") from None
        assert reply is not None, f"the cluster's process ended before {what}; {self._tail()}"
        return reply

    def _tail(self) -> str:
        return f"its log ends: {self._log.read_text()[-3000:]}"

    def actors(self) -> list[dict]:
        self._process.stdin.write("actors\n")
        self._process.stdin.flush()
        return self._reply(60, "the actor table")

    def stop(self) -> list[int]:
        if self.left is None:
            self._process.stdin.write("stop\n")
            self._process.stdin.flush()
            self.left = self._reply(START_S, "the cluster to stop")["left"]
            assert self._process.wait(timeout=60) == 0, self._tail()
        return self.left

    def _end(self) -> None:
        """Stop the helper whatever state it is in: its nodes' reapers end their processes
        when it is gone."""
        with contextlib.suppress(OSError):
            self._process.stdin.close()  # the end of stdin: the helper stops the cluster
        try:
            self._process.wait(timeout=START_S)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()

    def __exit__(self, *exc) -> None:
        if self.left is None:
            try:
                self.stop()
            finally:
                self._end()


def _train(out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "rllib_pommer.train", "--out", str(out), *extra]


def _leg_checkpoints(out: Path, leg: int) -> list[Path]:
    """The whole checkpoints of the run's leg number `leg` (1: the first)."""
    trials = [trial for trial in out.glob("PPO_*") if len(legs(trial)) == leg]
    return [c for trial in trials for c in trial.glob("checkpoint_*") if checkpoint_complete(c)]


def _stop(process: subprocess.Popen, out: Path, leg: int, after: int) -> Path:
    """`train --stop` the run's leg number `leg` once it has checkpointed `after` iterations (0:
    once its driver is noted in the run folder, so that the request is its own): the iteration
    under way is the last. The checkpoint it stopped at."""
    deadline = time.monotonic() + RUN_S
    while (ray_session.live_driver(out) != process.pid
           or len(_leg_checkpoints(out, leg)) < after):
        assert process.poll() is None, f"training ended first ({process.returncode})"
        assert time.monotonic() < deadline, "timed out waiting for the run"
        time.sleep(0.2)
    stop = subprocess.run(_train(out, "--stop"), cwd=REPO, capture_output=True, text=True,
                          timeout=RUN_S)
    assert stop.returncode == 0, stop.stderr[-3000:]
    assert process.wait(timeout=RUN_S) == 130  # stopped, as on Ctrl-C, with more to train
    return max(_leg_checkpoints(out, leg), key=checkpoint_iteration)


def _results(trial: Path) -> list[dict]:
    return [json.loads(line) for line in (trial / "result.json").read_text().splitlines()
            if line]


@pytest.mark.timeout(900)
def test_a_run_trains_on_five_nodes_then_resumes_on_a_ray_of_its_own(tmp_path, pi_weights):
    curriculum = tmp_path / "long_smoke.toml"
    smoke = (REPO / "curriculum" / "smoke.toml").read_text()
    assert 'opponent = "static"\nepisodes = 12' in smoke
    curriculum.write_text(smoke.replace('opponent = "static"\nepisodes = 12',
                                        'opponent = "static"\nepisodes = 100000'))
    out = tmp_path / "run"
    start = ["--curriculum", str(curriculum), "--pi-weights", str(pi_weights)]
    with RayCluster(NODES, tmp_path / "cluster.log") as cluster:
        assert sorted(cluster.nodes) == NODE_NAMES
        address = ["--address", cluster.address]
        # 1 CPU for the algorithm's process, 2 for the learners and 3 for the runners, where the
        # nodes have 5 together; a learner of 2 CPUs, where each node has 1 (3 CPUs in all).
        refusals = {"runners": ["--num-learners", "2", "--num-env-runners", "3"],
                    "learner": ["--num-learners", "1", "--num-cpus-per-learner", "2"]}
        refusing = {name: subprocess.Popen(_train(tmp_path / name, *start, *address, *options),
                                           cwd=REPO, stdout=subprocess.DEVNULL,
                                           stderr=subprocess.PIPE, text=True)
                    for name, options in refusals.items()}
        said = {name: process.communicate(timeout=RUN_S) for name, process in refusing.items()}
        for name, process in refusing.items():
            err = said[name][1]
            assert process.returncode == 2 and "Traceback" not in err, err[-3000:]
            errors = [line for line in err.splitlines() if "error:" in line]
            assert len(errors) == 1, err[-3000:]
            assert not (tmp_path / name).exists()
            said[name] = errors[0].removeprefix(
                f"python -m rllib_pommer.train: error: the Ray cluster at {cluster.address!r} ")
        assert said["runners"] == (
            "has 5 free CPUs; the run asks for 6 (1 for the algorithm's process, 2 for "
            "--num-learners 2, 3 for --num-env-runners 3): pass --num-env-runners 2 or fewer, "
            "or free or add CPUs"), said["runners"]
        assert said["learner"] == (
            "has no node with 2 CPUs for each of --num-learners 1 (--num-cpus-per-learner 2), "
            "which Ray places on one node; its nodes have at most 1 CPUs: ask for that or less, "
            "or add a bigger node"), said["learner"]

        process = subprocess.Popen(_train(out, *start, *address, "--num-learners", "2",
                                          "--num-env-runners", "2"),
                                   cwd=REPO, stdout=subprocess.DEVNULL,
                                   stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            on_cluster = _stop(process, out, leg=1, after=1)  # in the second iteration
        finally:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
        actors = cluster.actors()
        session_dir = cluster.session_dir
        left = cluster.stop()

    assert left == [] and ray_session.session_processes(session_dir) == []
    # Every actor the cluster ever had is the run's (the refused runs made none), each on a node
    # of its own: the learners updated, and the runners sampled, on nodes apart from each other
    # and from the algorithm's.
    assert Counter(actor["class"] for actor in actors) == {"PPO": 1, LEARNER: 2, RUNNER: 2}, \
        actors
    assert sorted(actor["node"] for actor in actors) == NODE_NAMES, actors
    assert len({actor["pid"] for actor in actors}) == len(NODE_NAMES)
    cluster_rows = _results(on_cluster.parent)
    assert {row["fault_tolerance"]["num_healthy_workers"] for row in cluster_rows} == {2}
    assert cluster_rows[-1]["training_iteration"] >= 2

    # On a Ray instance of its own (no --address, no learner actors, no runners), from the
    # checkpoint the cluster's learners wrote.
    log = tmp_path / "resume.log"
    with open(log, "w") as stderr:
        process = subprocess.Popen(_train(out, "--resume"), cwd=REPO, stdout=subprocess.DEVNULL,
                                   stderr=stderr, start_new_session=True)
    try:
        _stop(process, out, leg=2, after=0)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    said = log.read_text()
    assert f"resuming from {on_cluster.parent.name}/{on_cluster.name}" in said, said[-3000:]
    (resumed,) = [trial for trial in out.glob("PPO_*") if len(legs(trial)) == 2]
    first = _results(resumed)[0]
    iteration = checkpoint_iteration(on_cluster)
    (at_checkpoint,) = [row for row in cluster_rows if row["training_iteration"] == iteration]
    assert first["training_iteration"] == iteration + 1
    assert first["curriculum"]["episodes"] > at_checkpoint["curriculum"]["episodes"]
    assert first["curriculum"]["stage_name"] == "static"
    assert first["fault_tolerance"]["num_healthy_workers"] == 0


def test_a_learner_no_single_node_holds_is_refused(monkeypatch):
    """Ray places a learner's CPUs and GPUs on one node: enough of them over all the nodes is
    not enough (and a dead node holds nothing)."""
    nodes = [{"Alive": True, "Resources": {"CPU": 4.0, "GPU": 1.0}},
             {"Alive": True, "Resources": {"CPU": 4.0, "GPU": 1.0}},
             {"Alive": False, "Resources": {"CPU": 64.0, "GPU": 8.0}}]
    monkeypatch.setattr(ray, "nodes", lambda: nodes)
    fits = RunSettings(address="auto", num_learners=2, num_cpus_per_learner=4,
                       num_gpus_per_learner=1)
    check_learner_fits_a_node(fits)  # one learner on each node
    with pytest.raises(ValueError, match=r"has no node with 1 CPUs and 2 GPUs for each of "
                                         r"--num-learners 1 \(--num-cpus-per-learner 1, "
                                         r"--num-gpus-per-learner 2\), which Ray places on one "
                                         r"node; its nodes have at most 4 CPUs and 1 GPUs"):
        check_learner_fits_a_node(RunSettings(address="auto", num_learners=1,
                                              num_gpus_per_learner=2))
    with pytest.raises(ValueError, match=r"has no node with 6 CPUs for the learner in the "
                                         r"algorithm's process \(--num-cpus-per-learner 6\)"):
        check_learner_fits_a_node(RunSettings(address="auto", num_cpus_per_learner=6))
    monkeypatch.setattr(ray, "nodes", lambda: pytest.fail("a one-CPU learner needs no look"))
    check_learner_fits_a_node(RunSettings(address="auto", num_learners=3))
