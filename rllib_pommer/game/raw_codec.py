"""One agent's `Observation` as one flat int16 vector, and back, exactly.

Envs hand each agent a "raw" vector beside the network's planes (`envs/team.py`), so that any
policy can sit in any seat: scripted rules and the learner's filters rebuild from it the very
arrays the engine emitted and the arena gives them. Every field fits int16 (codes, lives and
strengths are small, positions and step counts below 2**15); the fields are laid out in
`Observation`'s order, each flattened.
"""

from __future__ import annotations

import numpy as np

from .observation import Observation, empty_observations

_TEMPLATE = empty_observations(1).select(0, 0)
_FIELD_SHAPES = [np.shape(field) for field in _TEMPLATE]
_FIELD_SIZES = [int(np.prod(shape)) for shape in _FIELD_SHAPES]
_SPLITS = np.cumsum(_FIELD_SIZES)[:-1]
RAW_SIZE = sum(_FIELD_SIZES)


def pack_raw(obs: Observation) -> np.ndarray:
    """Observations of leading shape L -> int16 (L..., RAW_SIZE)."""
    lead = obs.board.shape[:-2]
    return np.concatenate(
        [np.asarray(f).reshape(lead + (-1,)).astype(np.int16) for f in obs], axis=-1)


def unpack_raw(raw: np.ndarray) -> Observation:
    """The inverse of `pack_raw`, with the engine's dtypes, for any leading shape."""
    raw = np.asarray(raw)
    lead = raw.shape[:-1]
    parts = np.split(raw, _SPLITS, axis=-1)
    return Observation(*(
        part.reshape(lead + shape).astype(np.asarray(template).dtype)
        for part, shape, template in zip(parts, _FIELD_SHAPES, _TEMPLATE, strict=True)))
