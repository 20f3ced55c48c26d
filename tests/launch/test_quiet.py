"""Ray's start-up noise is dropped, and nothing else is."""

from __future__ import annotations

import logging
import subprocess
import sys

from rllib_pommer.launch import quiet


def test_silence_drops_each_noise_message_and_keeps_other_warnings(caplog):
    quiet.silence()
    quiet.silence()  # idempotent: one filter per logger
    with caplog.at_level(logging.WARNING):
        for name, text in quiet.NOISE.items():
            logger = logging.getLogger(name)
            assert sum(isinstance(f, quiet._DropNoise) for f in logger.filters) == 1
            logger.warning("prefix %s suffix", text)
            logger.warning("a warning that matters, from %s", name)
    messages = [record.getMessage() for record in caplog.records]
    assert messages == [f"a warning that matters, from {name}" for name in quiet.NOISE]


def test_every_ray_worker_of_a_run_drops_the_noise():
    """`init_ray` hands Ray `silence` as the worker setup hook: a task in a worker of the run's
    Ray finds the filter on each noisy logger (a fresh interpreter: Ray starts once a process)."""
    code = ("import logging, ray\n"
            "from rllib_pommer.launch import quiet\n"
            "from rllib_pommer.launch.training import init_ray\n"
            "init_ray(None, num_cpus=1)\n"
            "@ray.remote\n"
            "def filtered():\n"
            "    return [any(isinstance(f, quiet._DropNoise) for f in "
            "logging.getLogger(name).filters) for name in quiet.NOISE]\n"
            "print(all(ray.get(filtered.remote())))\n"
            "ray.shutdown()\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=240, check=True).stdout
    assert out.strip().splitlines()[-1] == "True"
