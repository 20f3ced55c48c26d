"""Ray's start-up messages that tell a user of this project nothing, dropped from Ray's loggers.

Ray prints them when a run starts, before any progress line, and none asks anything of the user:
- "Token authentication is enabled for this Ray cluster": Ray 2.60 turns token authentication on
  for every new local instance; ours is one, and keeps it on (a client of a `ray start` cluster
  needs `RAY_AUTH_MODE=token`, which `init_ray`'s error says);
- "You are running PPO on the new API stack!", once in the driver and once in the algorithm's
  process: RLlib's default, which this project is written for;
- "`RLModule(config=[RLModuleConfig object])` has been deprecated": RLlib's own `RLModule.__init__`
  builds that object for old custom models; our modules never pass one;
- "Install gputil for GPU system monitoring": Tune's monitor, on CPU-only machines;
- "Trainable.setup took N seconds ... reuse_actors": a hint for many trials; a run is one trial;
- "Experiment has been interrupted ... Resume experiment with: Tuner.restore(...)": a run resumes
  from its data with `train --resume` (training.py), which the job's own last line names.

Every other warning passes. `silence` runs in the driver (`training.init_ray`) and, as Ray's
`worker_process_setup_hook`, in every Ray worker process, where the algorithm logs its own copy.
"""

from __future__ import annotations

import logging

# Logger name -> text that marks the one message dropped from it.
NOISE = {
    "ray._private.authentication.authentication_token_setup":
        "Token authentication is enabled for this Ray cluster",
    "ray.rllib.algorithms.algorithm_config": "on the new API stack!",
    "ray._common.deprecation": "RLModule(config=[RLModuleConfig object])",
    "ray.tune.utils.util": "Install gputil",
    "ray.tune.trainable.trainable": "consider setting reuse_actors=True",
    "ray.tune.tune": "Resume experiment with: Tuner.restore",
}


class _DropNoise(logging.Filter):
    def __init__(self, text: str):
        super().__init__()
        self.text = text

    def filter(self, record: logging.LogRecord) -> bool:
        return self.text not in record.getMessage()


def silence() -> None:
    """Drop the messages of `NOISE` in this process (idempotent)."""
    for name, text in NOISE.items():
        logger = logging.getLogger(name)
        if not any(isinstance(f, _DropNoise) and f.text == text for f in logger.filters):
            logger.addFilter(_DropNoise(text))
