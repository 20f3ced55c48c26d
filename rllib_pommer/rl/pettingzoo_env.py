"""The PettingZoo env's old home: it lives in `rllib_pommer.envs` (no Ray); kept importable here
for code written against this path."""

from __future__ import annotations

from ..envs.multi_agent import PommeParallelEnv

__all__ = ["PommeParallelEnv"]
