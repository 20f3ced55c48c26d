"""The RL tests' fixtures the runs/ tests share (tests/rl/conftest.py)."""

from ..rl.conftest import committed_campaign  # noqa: F401  (the fixture)
