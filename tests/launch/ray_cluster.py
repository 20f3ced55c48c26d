"""A Ray cluster of several nodes on this machine for the tests, kept in a process of its own.

Ray's test utility (`ray.cluster_utils.Cluster`) starts a head and worker nodes, each a raylet
with its own logical CPUs and resources, all in one session folder. It runs here, in a child
process, and not in the test's: the Ray state it touches in its process (a GCS client, the
internal key-value store it resets on shutdown) would otherwise be the test process's, which
other tests' Ray instances use.

    python tests/launch/ray_cluster.py '[{"CPU": 1, "head": 1}, {"CPU": 1, "worker_a": 1}]'

starts one node per resource table (the first is the head; a node's one custom resource names
it) and prints a line `CLUSTER <json>`: the cluster's address, its session folder and each
node's id by name. Each line then read on stdin is answered with one such line: "actors" gives
every actor the cluster has known, alive or dead (class, state, node name, pid). A line "stop",
or the end of stdin (the test process gone), removes every node, ends what the nodes' raylets
started and left (Ray's agents outlive a killed raylet), waits until no process of the session
is left, and prints `{"stopped": true, "left": [pids still running]}` before exiting.

On a loaded machine Ray's own waits are too short: a raylet gives its agents a fixed 15 s to
write their ports to files, and a new node a fixed 30 s to register. So each node gets its
agents' ports up front (then the raylet reads them from its command line), and the registration
is waited for longer.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import socket
import sys
import time

from ray._private import ray_constants
from ray.exceptions import RaySystemError

from rllib_pommer.launch.ray_session import session_processes

START_WAIT_S = 300.0  # for a node to come up
STOP_WAIT_S = 60.0  # for its processes to exit
# The wait for the GCS to publish its port, read by the Ray processes this one starts.
os.environ.setdefault("RAY_gcs_server_port_wait_time_s", str(int(START_WAIT_S)))
AGENT_PORTS = ("metrics_agent_port", "dashboard_agent_listen_port", "runtime_env_agent_port",
               "metrics_export_port")


def say(reply) -> None:
    print("CLUSTER " + json.dumps(reply), flush=True)


def _free_ports(count: int) -> list[int]:
    """`count` distinct TCP ports free now."""
    sockets = [socket.socket() for _ in range(count)]
    try:
        for sock in sockets:
            sock.bind(("", 0))
        return [sock.getsockname()[1] for sock in sockets]
    finally:
        for sock in sockets:
            sock.close()


def _patient_get_node(get_node, wait_s: float):
    """Ray's `services.get_node`, retried for up to `wait_s` while the node is not registered
    or the GCS does not answer."""
    def patient(gcs_address, node_id):
        deadline = time.monotonic() + wait_s
        while True:
            try:
                return get_node(gcs_address, node_id)
            except (RuntimeError, RaySystemError):
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.5)
    return patient


def _raylet_told_its_agent_port(start_ray_process):
    """Ray's `services.start_ray_process`, giving a raylet the port its dashboard agent listens
    on where the agent's command names one (Ray 2.60 passes the others, not this one)."""
    def start(command, process_type, *args, **kwargs):
        if process_type == ray_constants.PROCESS_TYPE_RAYLET:
            agent = next((part for part in command
                          if part.startswith("--dashboard_agent_command=")), "")
            port = re.search(r"--listen-port=(\d+)", agent)
            if port and int(port.group(1)):
                command = [*command, f"--dashboard_agent_listen_port={port.group(1)}"]
        return start_ray_process(command, process_type, *args, **kwargs)
    return start


def _end_session(session_dir: str) -> list[int]:
    """End every process left in the session (SIGTERM, then SIGKILL); the pids still there
    after `STOP_WAIT_S`."""
    deadline = time.monotonic() + STOP_WAIT_S
    signalled: dict[int, float] = {}
    while (left := session_processes(session_dir)) and time.monotonic() < deadline:
        for pid in left:
            first = signalled.setdefault(pid, time.monotonic())
            kill = signal.SIGKILL if time.monotonic() - first > 5 else signal.SIGTERM
            with contextlib.suppress(ProcessLookupError, PermissionError):  # gone meanwhile
                os.kill(pid, kill)
        time.sleep(0.5)
    return session_processes(session_dir)


def main(spec: str) -> int:
    from ray._common.utils import get_default_ray_temp_dir
    from ray._private import services
    from ray.cluster_utils import Cluster

    services.get_node = _patient_get_node(services.get_node, START_WAIT_S)
    services.start_ray_process = _raylet_told_its_agent_port(services.start_ray_process)
    tables = json.loads(spec)
    ports = iter(_free_ports(len(AGENT_PORTS) * len(tables)))
    # The session's name and folder, known before the head starts, so that a failed start is
    # cleaned up too.
    temp_dir = get_default_ray_temp_dir()
    session = f"session_cluster_test_{time.strftime('%Y-%m-%d_%H-%M-%S')}_{os.getpid()}"
    session_dir = os.path.join(temp_dir, session)
    head = {"include_dashboard": False, "temp_dir": temp_dir, "session_name": session}
    cluster = Cluster()
    names = {}
    try:
        for index, table in enumerate(tables):
            custom = {key: value for key, value in table.items() if key not in ("CPU", "GPU")}
            extra = dict(head) if index == 0 else {}
            extra.update({name: next(ports) for name in AGENT_PORTS})
            node = cluster.add_node(num_cpus=table.get("CPU", 0), num_gpus=table.get("GPU", 0),
                                    resources=custom, **extra)
            assert node.get_session_dir_path() == session_dir, node.get_session_dir_path()
            (name,) = custom
            names[node.node_id] = name
        cluster.wait_for_nodes(timeout=START_WAIT_S)
        say({"address": cluster.address, "session_dir": session_dir,
             "nodes": {name: node_id for node_id, name in names.items()}})
        for line in sys.stdin:
            command = line.strip()
            if command == "stop":
                break
            if command == "actors":
                actors = cluster.global_state.actor_table(None)
                say([{"class": actor["ActorClassName"], "state": actor["State"],
                      "node": names.get(actor["Address"]["NodeID"], "?"), "pid": actor["Pid"]}
                     for actor in actors.values()])
            else:
                say({"error": f"unknown command {command!r}"})
    finally:
        cluster.shutdown()
        left = _end_session(session_dir)
    say({"stopped": True, "left": left})
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
