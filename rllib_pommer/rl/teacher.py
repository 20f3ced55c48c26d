"""Kickstarting (Schmitt et al. 2018, "Kickstarting Deep Reinforcement Learning"): PPO's loss plus
a pull toward a teacher's moves on the learner's own steps.

A curriculum's [ppo] table may name a `teacher`, any policy the arena plays (`search`, the tree
search agent, above all: it finishes careful teams that the learned agents tie,
docs/campaigns.md), and a `teacher_weight` w. On every step the learner acts,
`TeacherLabels`, a module-to-env connector piece, asks an agent of that policy what it would
do in the learner's place, from the same observation (the "raw" part, `game/raw_codec.py`),
and stores the move in the episode (column `TEACHER_COLUMN`), from where RLlib's learner
connector brings it into the train batch as it brings the module's other outputs. One teacher
agent per learner seat and episode lives in the episode's custom data, so its memory (the search
agent's belief, a scripted agent's random stream) follows that seat's game in order, seeded from
the episode's first observation as the filters' agents are (connectors.py); it sees what the
learner sees and nothing else.

The learner (learner.py) then adds w times the cross-entropy of pi's move logits against the
teacher's moves to PPO's loss for the learner module (not an exploiter, which has no teacher
rows), over the rows whose probability ratio is still inside PPO's clip (|log r| <= log(1 +
clip)), so that no row is pulled past the region PPO's own loss keeps it in. The weight must stay
small: with the paper's clip of 0.01 PPO's gradient vanishes from most rows after a few steps
while the cross-entropy's stays, and Adam scales the steps to it, so the pull becomes behaviour
cloning inside PPO. In `league2_kickstart`'s first tries, w 0.2 lost 0.93 of the learner's games
by the third iteration (1.9 of its agents a game to their own bombs; ppo_league's start: 0.07
and 0.2: moves copied from the search agent without the escape it plans), and 0.86 by the
fourth with the clip's mask, which bounds each row, not pi: every minibatch brings fresh rows.
At w 0.02 the collapse came more slowly: over iterations 10-19 the learner lost 0.59 of its
games with 1.31 own-bomb deaths a game (the memory arm at the same point: 0.13 and 0.52), pi's
most likely move agreeing with the teacher's on 0.68 of the rows (docs/campaigns.md). The
learner logs
the cross-entropy and how often pi's most likely move is the teacher's, each a mean over the
last 100 minibatches (`teacher_xent`, `teacher_agreement`). The teacher costs sampling time: one
decision per learner step (the search agent's p50 is 0.4 ms: docs/measurements.md).
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F
from ray.rllib.connectors.connector_v2 import ConnectorV2
from ray.rllib.core.columns import Columns

from ..agents.registry import make_agent
from ..curriculum.names import LEARNER
from ..game.constants import NUM_ACTIONS, TEAM_PRESET
from ..game.raw_codec import unpack_raw

TEACHER_COLUMN = "teacher_action"
TEACHER_KEY = "teacher"  # the episode's custom data: seat -> its teacher agent
TEACHER_WEIGHT_KEY = "teacher_weight"  # in the config's learner_config_dict


class TeacherLabels(ConnectorV2):
    """Module-to-env piece: the teacher's move for each learner step (module docstring)."""

    def __init__(self, *args, teacher: str, **kwargs):
        super().__init__(*args, **kwargs)
        self.teacher = teacher

    def __call__(self, *, rl_module, batch, episodes, explore=None, shared_data=None,
                 metrics=None, **kwargs):
        by_id = {episode.id_: episode for episode in episodes}
        labels = {}
        for key in batch[Columns.ACTIONS]:
            episode_id, agent_id, module_id = key
            if module_id != LEARNER:
                continue
            episode = by_id[episode_id]
            raw = episode.agent_episodes[agent_id].get_observations(-1)["raw"]
            teachers = episode.custom_data.setdefault(TEACHER_KEY, {})
            if agent_id not in teachers:
                teachers[agent_id] = teacher_agent(self.teacher, agent_id, raw)
            labels[key] = [np.int64(teachers[agent_id].act(unpack_raw(raw)))]
        if labels:
            batch[TEACHER_COLUMN] = labels
        return batch


def teacher_agent(policy: str, seat: int, first_raw: np.ndarray):
    """An agent of `policy` for one learner seat's game, seeded from its first observation."""
    agent = make_agent(policy)
    agent.reset(seat, int(TEAM_PRESET.game_type),
                np.random.default_rng(np.frombuffer(first_raw.tobytes(), np.uint8)))
    return agent


def teacher_loss(logits: torch.Tensor, teacher: torch.Tensor,
                 rows: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The cross-entropy of the move logits (rows, 6+) against the teacher's moves (rows,) over
    the `rows` mask (mean; 0 with a gradient if none), and the share of them where pi's most
    likely move is the teacher's."""
    moves = logits[..., :NUM_ACTIONS][rows]
    target = teacher.long()[rows]
    if not len(target):
        return logits.sum() * 0.0, torch.tensor(float("nan"))
    agreement = (moves.argmax(-1) == target).float().mean()
    return F.cross_entropy(moves, target), agreement
