"""The RL tests' fixtures the launch/ tests share (tests/rl/conftest.py)."""

from ..rl.conftest import pi_weights, ray_session  # noqa: F401  (the fixtures)
