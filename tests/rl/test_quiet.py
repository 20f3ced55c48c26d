"""Ray's start-up noise is dropped, and nothing else is."""

from __future__ import annotations

import importlib
import logging

from rllib_pommer.rl import quiet
from rllib_pommer.rl.training import init_ray


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


def test_the_worker_hook_names_silence():
    import inspect

    source = inspect.getsource(init_ray)
    hook = "rllib_pommer.rl.quiet.silence"
    assert f'"worker_process_setup_hook": "{hook}"' in source
    module, _, function = hook.rpartition(".")
    assert getattr(importlib.import_module(module), function) is quiet.silence
