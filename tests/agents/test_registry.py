"""Policy names, policy files, filter suffixes and their errors."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from rllib_pommer.agents import registry
from rllib_pommer.agents.action_filter import ActionFilter
from rllib_pommer.agents.base import Agent
from rllib_pommer.agents.jitter import JitterCorrection
from rllib_pommer.agents.registry import make_agent, policy_names, resolve_policy
from rllib_pommer.agents.scripted import SmartRandom, StaticAgent, SuicideTeammate
from rllib_pommer.agents.simple import SimpleAgent

SHIPPED = ["imitation", "imitation_sampling", "imitation_v1", "imitation_v2", "ppo",
           "ppo_cautious", "ppo_dual_clip", "ppo_league", "ppo_league_v1", "ppo_team", "random",
           "search", "search_fast", "simple", "simple_nobomb", "smart_random", "static", "suicide"]


def layers(agent):
    """Class names from the outermost wrapper down to the wrapped agent."""
    names = [type(agent).__name__]
    while hasattr(agent, "inner"):
        agent = agent.inner
        names.append(type(agent).__name__)
    return names


def test_every_shipped_policy_builds_an_agent():
    assert policy_names() == SHIPPED
    for name in SHIPPED:
        spec = resolve_policy(name)
        assert spec.name == name and spec.kind in registry.KINDS and spec.description
        assert spec.filters == ()
        assert isinstance(make_agent(name), Agent)


@pytest.mark.parametrize(
    "name, expected",
    [
        ("simple", ["SimpleAgent"]),
        ("simple_action", ["ActionFilter", "SimpleAgent"]),
        ("simple_jitter", ["JitterCorrection", "SimpleAgent"]),
        ("simple_jitter_action", ["ActionFilter", "JitterCorrection", "SimpleAgent"]),
        ("simple_nobomb_action", ["ActionFilter", "SimpleAgentNoBomb"]),
        ("static_jitter", ["JitterCorrection", "StaticAgent"]),
        ("simple_words", ["Speaker", "SimpleAgent"]),
        ("simple_jitter_action_words", ["Speaker", "ActionFilter", "JitterCorrection",
                                        "SimpleAgent"]),
    ],
)
def test_suffixes_add_the_wrappers(name, expected):
    assert layers(make_agent(name)) == expected


def test_filters_argument_stacks_jitter_inside_action_once():
    expected = ["ActionFilter", "JitterCorrection", "SmartRandom"]
    assert layers(make_agent("smart_random", filters=["action", "jitter"])) == expected
    assert layers(make_agent("smart_random_action", filters=("jitter", "action"))) == expected
    assert layers(make_agent("smart_random", filters="action")) == ["ActionFilter", "SmartRandom"]


def test_episode_switches_build_the_same_stack_as_the_names():
    """The env's per-episode switches (as a curriculum stage names them) turn on the registry's
    filters, stacked as make_agent stacks them."""
    assert registry.switched_on({"action_filter": True, "jitter": True}) == ("jitter", "action")
    assert registry.switched_on({"action_filter": True, "jitter": False}) == ("action",)
    assert registry.switched_on({"jitter": True}) == ("jitter",)
    assert registry.switched_on({}) == ()
    stack = registry.with_filters(StaticAgent(), registry.switched_on(
        {"action_filter": True, "jitter": True}))
    assert layers(stack) == ["ActionFilter", "JitterCorrection", "StaticAgent"]
    with pytest.raises(ValueError, match=r"unknown filter switch\(es\) \['action'\]"):
        registry.switched_on({"action": True})
    with pytest.raises(ValueError, match=r"unknown filter\(s\) \['action_filter'\]"):
        registry.with_filters(StaticAgent(), ["action_filter"])


def test_the_registry_loads_requests_only_for_a_remote_agent():
    """The http kind is a plugin: its module, and `requests`, load when one is first built."""
    code = ("import sys\nimport rllib_pommer.agents.registry as registry\n"
            "print('requests' in sys.modules, 'rllib_pommer.agents.http_agent' in sys.modules)\n"
            "registry.make_agent('simple_action')\nprint('requests' in sys.modules)\n"
            "registry.registered('http')\nprint('requests' in sys.modules)")
    lines = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           check=True).stdout.split()
    assert lines == ["False", "False", "False", "True"]


def test_a_remote_policy_file_builds_an_http_agent(tmp_path):
    path = tmp_path / "remote.toml"
    path.write_text('kind = "http"\ndescription = "a container"\nport = [10080, 10081]\n')
    agent = make_agent(path)
    assert type(agent).__name__ == "HttpAgent" and agent.ports == (10080, 10081)
    path.write_text('kind = "http"\nport = 10080\nhots = "x"\n')
    with pytest.raises(ValueError, match=r"unknown key\(s\) \['hots'\] for kind 'http'"):
        make_agent(path)


def test_a_written_policy_file_reads_back_as_written(tmp_path):
    path = tmp_path / "deep.toml"
    description = 'search, "deeper" \\ café'
    assert registry.write_policy_file(path, "search", description, depth=3, recall=2) == path
    assert path.read_text(encoding="utf-8").splitlines()[0] == 'kind = "search"'
    spec = resolve_policy(path)
    assert (spec.kind, spec.description, dict(spec.params)) == (
        "search", description, {"depth": 3, "recall": 2})
    registry.write_policy_file(path, "learned", "a clone", weights="w/pi.pt", greedy=False,
                               temperature=0.5)
    assert registry.acting(resolve_policy(path)) == registry.Acting(False, 0.5)


@pytest.mark.parametrize(("kind", "params", "message"), [
    ("search", {"dept": 3}, r"unknown key 'dept' for kind 'search'"),
    ("learned", {"weights": 3}, "weights must be a str, got 3"),
    ("learned", {}, "kind 'learned' needs key 'weights'"),
    ("scripted", {}, "kind 'scripted' is not one of"),
    ("learned", {"weights": "pi.pt", "temperature": float("nan")}, "finite numbers, not nan"),
])
def test_a_policy_file_the_reader_would_refuse_is_not_written(tmp_path, kind, params, message):
    path = tmp_path / "bad.toml"
    with pytest.raises(ValueError, match=message):
        registry.write_policy_file(path, kind, "bad", **params)
    assert not path.exists()


def test_each_call_builds_fresh_agents():
    first, second = make_agent("simple_jitter_action"), make_agent("simple_jitter_action")
    assert first is not second and first.inner is not second.inner
    assert isinstance(first, ActionFilter) and isinstance(first.inner, JitterCorrection)
    assert isinstance(first.inner.expert, SimpleAgent)
    assert first.inner.expert is not second.inner.expert


def test_unknown_policy_lists_the_valid_names():
    with pytest.raises(ValueError, match="unknown policy 'simpel'") as info:
        make_agent("simpel")
    for name in SHIPPED:
        assert repr(name) in str(info.value)
    assert "_jitter_action" in str(info.value)
    with pytest.raises(ValueError, match="unknown policy"):
        resolve_policy("simple_action_jitter")
    with pytest.raises(ValueError, match="unknown policy 'simple_words_action'.*'_words'"):
        resolve_policy("simple_words_action")
    assert resolve_policy("simple_action_words").words
    assert not resolve_policy("simple_action").words


def test_unknown_filter_lists_the_valid_ones():
    with pytest.raises(ValueError, match=r"\['jitter', 'action'\]"):
        make_agent("simple", filters=["jitter", "actoin"])


def test_policy_file_by_path(tmp_path):
    path = tmp_path / "lazy.toml"
    path.write_text('kind = "static"\ndescription = "does nothing"\n')
    spec = resolve_policy(path)
    assert (spec.name, spec.kind, spec.description, spec.path) == (
        "lazy",
        "static",
        "does nothing",
        path,
    )
    assert isinstance(make_agent(str(path)), StaticAgent)
    assert layers(make_agent(path, filters=["action"])) == ["ActionFilter", "StaticAgent"]
    with pytest.raises(ValueError, match="does not exist"):
        resolve_policy(tmp_path / "missing.toml")


def test_bad_policy_files_name_the_problem(tmp_path):
    unknown = tmp_path / "alien.toml"
    unknown.write_text('kind = "alien"\n')
    with pytest.raises(ValueError, match=r"kind 'alien' is not one of \[.*'smart_random'"):
        resolve_policy(unknown)
    missing = tmp_path / "blank.toml"
    missing.write_text('description = "no kind"\n')
    with pytest.raises(ValueError, match="kind None is not one of"):
        resolve_policy(missing)
    broken = tmp_path / "broken.toml"
    broken.write_text("kind = \n")
    with pytest.raises(ValueError, match="invalid TOML"):
        resolve_policy(broken)


def test_policies_folder_override(tmp_path, monkeypatch):
    (tmp_path / "kamikaze.toml").write_text('kind = "suicide"\ndescription = "x"\n')
    monkeypatch.setenv(registry.POLICIES_ENV_VAR, str(tmp_path))
    assert policy_names() == ["kamikaze"]
    assert layers(make_agent("kamikaze_action")) == ["ActionFilter", "SuicideTeammate"]
    with pytest.raises(ValueError, match=r"valid: \['kamikaze'\]"):
        make_agent("simple")


def test_new_kinds_can_be_registered_with_parameters(tmp_path, monkeypatch):
    seen = {}

    def build(spec):
        seen.update(spec.params)
        return SuicideTeammate() if spec.params["brave"] else SmartRandom()

    monkeypatch.setitem(registry.KINDS, "custom", registry.Kind(build, keys=None))
    path = tmp_path / "ppo.toml"
    path.write_text('kind = "custom"\ndescription = "weights"\nbrave = true\nsteps = 3\n')
    assert isinstance(make_agent(path), SuicideTeammate)
    assert seen == {"brave": True, "steps": 3}
    monkeypatch.delitem(registry.KINDS, "custom")
    registry.register_kind("custom", build)
    assert registry.KINDS["custom"] == registry.Kind(build, keys=None)
    monkeypatch.delitem(registry.KINDS, "custom")


@pytest.mark.parametrize(("text", "message"), [
    ('kind = "learned"\nweights = "w.pt"\ngreedy = "no"\n', "greedy must be a bool, got 'no'"),
    ('kind = "learned"\nweights = 5\n', "weights must be a str, got 5"),
    ('kind = "learned"\ngreedy = true\n', "kind 'learned' needs key 'weights'"),
    ('kind = "learned"\nweights = "w.pt"\ngredy = true\n', "unknown key 'gredy'"),
    ('kind = "static"\nspeed = 3\n', "unknown key 'speed' for kind 'static'; valid: none"),
])
def test_policy_file_keys_are_checked_strictly(tmp_path, text, message):
    path = tmp_path / "p.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match=re.escape(message)) as info:
        resolve_policy(path)
    assert str(path) in str(info.value)
