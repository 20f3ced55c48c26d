"""Decoding the request bodies of the 2018 competition's agent protocol.

Every body is a JSON object whose values are themselves JSON-encoded strings (`{"id": "0"}`), as the
competition's runner sent them. A TeamRadio game (game type 3, the 2019 competition's) adds the
observation's `message`, the teammate's last two words. Each decoder raises `BadRequest` naming the
field and what is wrong with it, so a caller sees its own mistake instead of a server error, and the
server keeps running.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from ..game.constants import NUM_AGENTS, GameType, has_radio, has_teams, teammate_of
from ..game.observation import Observation
from ..game.serialize import load_observation, load_words

# Bit generators whose `state` is plain JSON (ints only), so a caller's stream can be sent exactly.
JSON_STATE_BIT_GENERATORS = {cls.__name__: cls for cls in (np.random.PCG64, np.random.PCG64DXSM)}


class BadRequest(ValueError):
    """A malformed request: answered with HTTP 400 and this message."""


GAME_TYPES = range(min(GameType), max(GameType) + 1)


class InitAgent(NamedTuple):
    """A decoded `/init_agent` body."""
    agent_id: int
    game_type: int
    seed: np.random.Generator | None  # None: the caller sent no seed (the protocol has none)


def parse_body(raw: bytes) -> Mapping[str, Any]:
    try:
        body = json.loads(raw)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BadRequest(f"request body is not JSON ({exc})") from None
    except RecursionError:
        raise BadRequest("request body is nested too deeply") from None
    if not isinstance(body, dict):
        raise BadRequest(f"request body must be a JSON object, got {type(body).__name__}")
    return body


def _decoded(body: Mapping[str, Any], key: str, required: bool = True) -> Any:
    """The value of field `key`, a JSON-encoded string, decoded."""
    if key not in body:
        if required:
            raise BadRequest(f"missing field {key!r}")
        return None
    text = body[key]
    if not isinstance(text, str):
        raise BadRequest(
            f"field {key!r} must be a JSON-encoded string (e.g. \"2\"), got {json.dumps(text):.60}"
        )
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise BadRequest(f"field {key!r} does not hold JSON ({exc})") from None
    except RecursionError:
        raise BadRequest(f"field {key!r} is nested too deeply") from None


def _integer(value: Any, key: str, allowed: range | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise BadRequest(f"field {key!r} must encode an integer, got {json.dumps(value):.60}")
    if allowed is not None and value not in allowed:
        raise BadRequest(
            f"field {key!r} must be in {allowed.start}..{allowed.stop - 1}, got {value}"
        )
    return value


def rng_from_seed(seed: Any) -> np.random.Generator:
    """Our extension's `seed`: a non-negative integer (fed to `default_rng`) or a numpy
    bit-generator state object, which continues the caller's own stream exactly. A state does not
    carry the caller's seed sequence, which child streams (`spawn`: the filters', a `_words`
    agent's words) come from; the served generator's is derived from the state, so the same state
    gives the same children on every server start (not the caller's own children)."""
    if isinstance(seed, dict):
        name = seed.get("bit_generator")
        cls = JSON_STATE_BIT_GENERATORS.get(name) if isinstance(name, str) else None
        if cls is None:
            raise BadRequest(
                f"field 'seed': bit generator {seed.get('bit_generator')!r} is not one of "
                f"{sorted(JSON_STATE_BIT_GENERATORS)}"
            )
        digest = hashlib.sha256(json.dumps(seed, sort_keys=True).encode()).digest()
        bit_generator = cls(np.random.SeedSequence(int.from_bytes(digest, "little")))
        try:
            bit_generator.state = seed
        except (TypeError, ValueError, KeyError, OverflowError) as exc:
            raise BadRequest(f"field 'seed': not a valid {cls.__name__} state ({exc!r})") from None
        return np.random.Generator(bit_generator)
    if _integer(seed, "seed") < 0:
        raise BadRequest(f"field 'seed' must be non-negative, got {seed}")
    return np.random.default_rng(seed)


def parse_init_agent(body: Mapping[str, Any]) -> InitAgent:
    agent_id = _integer(_decoded(body, "id"), "id", range(NUM_AGENTS))
    game_type = _integer(_decoded(body, "game_type"), "game_type", GAME_TYPES)
    seed = _decoded(body, "seed", required=False)
    return InitAgent(agent_id, game_type, None if seed is None else rng_from_seed(seed))


class ActionRequest(NamedTuple):
    """A decoded `/action` body."""
    obs: Observation
    message: tuple[int, ...] | None  # TeamRadio: the words the agent hears; None in other games


def parse_action(body: Mapping[str, Any], agent_id: int, game_type: int) -> ActionRequest:
    """The observation of `/action` (with its `message` in TeamRadio), for the seat and game
    type of `/init_agent`. `action_space` is ignored: an agent's move is always one of six."""
    obs = _decoded(body, "obs")
    try:
        observation = load_observation(obs, agent_id)
        _check_game_type(observation, agent_id, game_type)
        message = load_words(obs.get("message"), f"observation of agent {agent_id}.message") \
            if has_radio(game_type) else None
    except (ValueError, OverflowError) as exc:
        raise BadRequest(str(exc)) from None
    _check_teammate(obs, observation, agent_id)
    return ActionRequest(observation, message)


def _check_game_type(observation: Observation, agent_id: int, game_type: int) -> None:
    """The game the observation comes from is the one `/init_agent` started: the agent plays
    by that one (in TeamRadio it hears the message and answers words)."""
    seen = int(observation.game_type)
    if seen != game_type:
        raise BadRequest(
            f"observation of agent {agent_id} is of game type {seen} ({GameType(seen).name}), "
            f"but /init_agent started game type {game_type} ({GameType(game_type).name}): "
            f"start each game with /init_agent of its own type"
        )


def _check_teammate(obs: Mapping[str, Any], observation: Observation, agent_id: int) -> None:
    """The only trace of the seat in an observation: catches two seats sharing one server."""
    teammate, expected = obs.get("teammate"), teammate_of(agent_id, GameType.TEAM)
    if has_teams(observation.game_type) and teammate is not None and teammate != expected:
        raise BadRequest(
            f"observation has teammate {teammate!r}, but agent {agent_id}'s teammate is "
            f"{expected}: one server plays one seat, so two seats need two servers"
        )


def parse_episode_end(body: Mapping[str, Any]) -> float:
    reward = _decoded(body, "reward")
    if isinstance(reward, bool) or not isinstance(reward, (int, float)):
        raise BadRequest(f"field 'reward' must encode a number, got {json.dumps(reward):.60}")
    return reward
