"""`train --address` on a Ray cluster of three nodes on this machine: Ray's own test utility
(`ray.cluster_utils.Cluster`, run by tests/launch/ray_cluster.py) starts a head and two worker
nodes of one logical CPU each, every node with a custom resource that names it. A run asking for
more CPUs than the three nodes have together is refused up front, in one line; a run with two
remote env runners trains on the cluster with each of its actors on a node of its own, stops at
a checkpoint with `train --stop`, and, once the cluster is gone with every process of its
session, resumes from its data on a Ray instance of its own."""

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

from rllib_pommer.launch import ray_session
from rllib_pommer.runs.checkpoints import checkpoint_complete, checkpoint_iteration
from rllib_pommer.runs.history import legs

from .ray_cluster import session_processes

REPO = Path(__file__).resolve().parents[2]
HELPER = Path(__file__).with_name("ray_cluster.py")
# One logical CPU per node, so that the run's three actors (the algorithm with its learner, two
# env runners) can only be placed one to a node.
NODES = [{"CPU": 1, "head": 1}, {"CPU": 1, "worker_a": 1}, {"CPU": 1, "worker_b": 1}]
START_S = 400.0  # for the cluster to come up, on a loaded machine too
RUN_S = 400.0  # for a training command to reach what the test waits for
RUNNER = "MultiAgentEnvRunner"


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
def test_a_run_trains_on_three_nodes_then_resumes_on_a_ray_of_its_own(tmp_path, pi_weights):
    curriculum = tmp_path / "long_smoke.toml"
    smoke = (REPO / "curriculum" / "smoke.toml").read_text()
    assert 'opponent = "static"\nepisodes = 12' in smoke
    curriculum.write_text(smoke.replace('opponent = "static"\nepisodes = 12',
                                        'opponent = "static"\nepisodes = 100000'))
    out = tmp_path / "run"
    start = ["--curriculum", str(curriculum), "--pi-weights", str(pi_weights)]
    with RayCluster(NODES, tmp_path / "cluster.log") as cluster:
        assert sorted(cluster.nodes) == ["head", "worker_a", "worker_b"]
        address = ["--address", cluster.address]
        # 1 CPU for the algorithm's process and 3 for the runners; the nodes have 3 together.
        refused = subprocess.run(_train(tmp_path / "too_big", *start, *address,
                                        "--num-env-runners", "3"),
                                 cwd=REPO, capture_output=True, text=True, timeout=RUN_S)
        assert refused.returncode == 2, refused.stderr[-3000:]
        errors = [line for line in refused.stderr.splitlines() if "error:" in line]
        assert len(errors) == 1 and "Traceback" not in refused.stderr, refused.stderr[-3000:]
        assert errors[0].startswith(
            f"python -m rllib_pommer.train: error: the Ray cluster at {cluster.address!r} has "
            f"3 free CPUs; the run asks for 4 ("), errors[0]
        assert "pass --num-env-runners 2 or fewer" in errors[0]

        process = subprocess.Popen(_train(out, *start, *address, "--num-env-runners", "2"),
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

    assert left == [] and session_processes(session_dir) == []
    # Every actor the cluster ever had is the run's (the refused run made none), each on a node
    # of its own: the runners sampled on the two nodes beside the learner's.
    assert Counter(actor["class"] for actor in actors) == {"PPO": 1, RUNNER: 2}, actors
    assert sorted(actor["node"] for actor in actors) == ["head", "worker_a", "worker_b"], actors
    assert len({actor["pid"] for actor in actors}) == 3
    cluster_rows = _results(on_cluster.parent)
    assert {row["fault_tolerance"]["num_healthy_workers"] for row in cluster_rows} == {2}
    assert cluster_rows[-1]["training_iteration"] >= 2

    # On a Ray instance of its own (no --address, no runners), from the cluster's checkpoint.
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
