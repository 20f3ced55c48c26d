"""The learner's filter stack in the module-to-env connector: built by the registry from the
episode's switches, as `make_agent` builds a named policy's (no Ray session needed)."""

from __future__ import annotations

import pytest

from rllib_pommer.agents.registry import make_agent
from rllib_pommer.envs.team import MultiAgentTeam
from rllib_pommer.rl.connectors import EpisodeFilters, fixed_filter_flags

from ..agents.test_registry import layers


@pytest.fixture(scope="module")
def first_raw():
    observations, _ = MultiAgentTeam({"observation": "dict"}).reset(seed=5)
    return observations[0]["raw"]


@pytest.mark.parametrize(("flags", "expected"), [
    ({"action_filter": False, "jitter": False}, ["ModuleAction"]),
    ({"action_filter": True, "jitter": False}, ["ActionFilter", "ModuleAction"]),
    ({"action_filter": False, "jitter": True}, ["JitterCorrection", "ModuleAction"]),
    ({"action_filter": True, "jitter": True},
     ["ActionFilter", "JitterCorrection", "ModuleAction"]),
])
def test_the_episode_switches_build_the_registry_stack(first_raw, flags, expected):
    filters = EpisodeFilters(flags, 0, first_raw)
    assert layers(filters.agent) == expected
    assert filters.flags is flags  # the callback logs the switches as the env drew them


@pytest.mark.parametrize("name", ["simple", "simple_action", "simple_jitter",
                                  "simple_jitter_action"])
def test_a_fixed_module_gets_the_stack_its_name_asks_for(first_raw, name):
    filters = EpisodeFilters(fixed_filter_flags(name), 1, first_raw)
    assert layers(filters.agent)[:-1] == layers(make_agent(name))[:-1]


def test_a_module_that_is_no_policy_name_has_no_filters():
    assert fixed_filter_flags("self_play_3") == {}


def test_an_unknown_switch_is_refused(first_raw):
    with pytest.raises(ValueError, match=r"unknown filter switch\(es\) \['action'\]"):
        EpisodeFilters({"action": True}, 0, first_raw)
