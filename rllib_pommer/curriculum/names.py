"""Names a training run shares with its data files and envs, importable without Ray or torch.

A curriculum file is checked (`curriculum.load_curriculum`) and a stage's seats are mapped
(`mapping.SeatMapping`) with these names alone, so neither needs Ray. (The reward modes, which
the envs share with the checker, are the game's: `game/rewards.py`.)
"""

from __future__ import annotations

LEARNER = "learner"  # module id of the trained policy; fixed modules are named by their policy
EXPLOITER = "exploiter"  # module id of a league's exploiter, trained to beat the learner alone
ENV_NAME = "pommerman_team"  # the RLlib env's registered name (rl/env.py)
# The learner's torch threads, for every process of a run's Ray job (launch/training.init_ray):
# how the machine is used, not what PPO computes, so it is no key of the run's config and applies
# to a resumed run too (learner.py reads it).
LEARNER_THREADS_ENV = "RLLIB_POMMER_LEARNER_THREADS"
