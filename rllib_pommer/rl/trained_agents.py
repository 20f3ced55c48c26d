"""The learner connector's first piece: only the agents of trained modules go on to the batch.

RLlib's learner turns every agent of every sampled episode into training rows (observations,
columns, time dimension, batching, tensors) and only then drops the rows of modules it does not
train. Here one seat in four is the learner; the teammate and the opponents are fixed modules, so
three quarters of that work would be thrown away. With this piece in front the learner batch is
bit-identical (tests/rl/test_trained_agents.py) and the connector several times faster
(`python -m rllib_pommer.bench learn` measures both side by side; docs/measurements.md).

The piece hands the rest of the pipeline a view of each multi-agent episode holding only the
trained agents' single-agent episodes; the episodes themselves are left whole, since the env
runner still sums their chunks into the episode metrics. It also leaves out a trained agent's
episode without a step, which RLlib's `AddOneTsToEpisodesAndTruncate` fails on: an env runner
sends none, but with several learners RLlib shards an iteration's episodes by slicing them, and a
slice may fall after the agent's death (rl/learner.py). `PommerPPOLearner.build` puts it at the
head of its pipeline, so a run resumed from a config saved before the piece existed gets it too.
"""

from __future__ import annotations

import copy
from collections.abc import Callable

from ray.rllib.connectors.connector_v2 import ConnectorV2
from ray.rllib.connectors.learner.learner_connector_pipeline import LearnerConnectorPipeline
from ray.rllib.env.multi_agent_episode import MultiAgentEpisode


class TrainedAgentsOnly(ConnectorV2):
    """Learner piece: replaces each multi-agent episode in `episodes` by a shallow view whose
    agents are those mapped to a module `trained(module_id)` accepts and with a step in it (the
    env-step length, and so the learner's env-step count, is unchanged)."""
    def __init__(self, trained: Callable[[str], bool], **kwargs):
        super().__init__(**kwargs)
        self._trained = trained

    def __call__(self, *, rl_module, batch, episodes, explore=None, shared_data=None,
                 metrics=None, **kwargs):
        for index, episode in enumerate(episodes):
            if isinstance(episode, MultiAgentEpisode):
                episodes[index] = self._view(episode)
        return batch

    def _view(self, episode: MultiAgentEpisode) -> MultiAgentEpisode:
        view = copy.copy(episode)
        view.agent_episodes = {agent: single for agent, single in episode.agent_episodes.items()
                               if self._trained(single.module_id) and len(single)}
        return view


def every_agent_pipeline(pipeline: LearnerConnectorPipeline) -> LearnerConnectorPipeline:
    """The pipeline RLlib builds, from ours without its `TrainedAgentsOnly` head (`bench learn`
    and the tests compare the two)."""
    head, *rest = pipeline.connectors
    if not isinstance(head, TrainedAgentsOnly):
        raise ValueError(f"the learner connector starts with {type(head).__name__}, "
                         f"not TrainedAgentsOnly")
    return LearnerConnectorPipeline(connectors=rest)
