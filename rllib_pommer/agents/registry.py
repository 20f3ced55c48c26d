"""Policies by name: small TOML files in the top-level `policies/` folder, plus filter suffixes.

A policy file holds a `kind`, a `description`, and any further keys its kind needs (e.g. a
weights path for learned kinds). Data files rather than code keep the set of named opponents
editable without touching the package. `KINDS` is the one table of kinds: how each builds its
agent, which keys its files hold, and which fixed RLlib module plays it in a curriculum (the
curriculum checker and `rl/fixed_modules.py` read it from here). Scripted kinds come from the
catalogue of rules (`scripted.RULES`); kinds whose code lies above this layer (torch, Ray) or
needs a heavy library (the remote agent's `requests`) name the module that registers their
factory (`register_kind`), imported only when an agent of that kind is built, so names resolve
and curricula check without torch, Ray or `requests`.

Names follow the paper's table: `X_jitter`, `X_action` and `X_jitter_action` are policy X under the
Jitter Correction, the Action Filter, or both. The wrappers are always stacked in the order of
`FILTERS`, jitter inside and action filter outside: the safety veto must have the last word, also
over the SimpleAgent moves that jitter correction injects (SimpleAgent walks into blasts too).
A last suffix `_words` (`simple_words`, `X_action_words`) makes the agent speak in TeamRadio games
(`speaker.Speaker`: seeded random words beside unchanged moves); without it agents are silent,
but for those that speak themselves (a learned radio network, a remote agent).

The folder is the repository's `policies/` (a wheel's copy of it), or the directory named by
RLLIB_POMMER_POLICIES: `shipped.data_dir` finds it from any working directory. The format has one
owner: `resolve_policy` reads the files and `write_policy_file` writes them (a trained policy's
file, written by imitation and by the run export).
"""

from __future__ import annotations

import importlib
import json
import math
import os
import sys
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..util.shipped import FOLDERS, data_dir
from ..util.toml_values import fits
from .action_filter import ActionFilter
from .base import Agent
from .jitter import JitterCorrection
from .scripted import RULES
from .search import SearchAgent
from .speaker import Speaker

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised only on Python 3.10
    import tomli as tomllib

POLICIES_ENV_VAR = FOLDERS["policies"]

# Wrapper name -> wrapper class, innermost first: this order is the stacking order.
FILTERS: dict[str, Callable[[Agent], Agent]] = {
    "jitter": JitterCorrection,
    "action": ActionFilter,
}
# Filter name -> its per-episode switch: the key of its probability in a curriculum stage and an
# env config, and of its flag in the env's `filters` info (on for this episode or not).
FILTER_SWITCHES = {"jitter": "jitter", "action": "action_filter"}
# Name suffix -> the filters it adds; the longest suffix is tried first.
FILTER_SUFFIXES = {
    "_jitter_action": ("jitter", "action"),
    "_action": ("action",),
    "_jitter": ("jitter",),
}
WORDS_SUFFIX = "_words"  # after any filter suffix: the agent speaks (TeamRadio)


@dataclass(frozen=True)
class PolicySpec:
    """A resolved policy: its file's contents plus the filters its name asked for."""

    name: str
    kind: str
    description: str
    path: Path
    params: Mapping[str, Any] = field(default_factory=dict)
    filters: tuple[str, ...] = ()
    words: bool = False  # the name ends in WORDS_SUFFIX: the agent speaks

    def file(self, key: str) -> Path:
        """The absolute path that key `key` names, relative to the policy file (a learned
        policy's weights, a checkpoint folder): a policy is found from any working directory."""
        if key not in self.params:
            raise ValueError(f"{self.path}: a {self.kind} policy needs a {key!r} key")
        return (self.path.parent / self.params[key]).resolve()


Factory = Callable[[PolicySpec], Agent]
KeySpec = Mapping[str, tuple[type, bool]]  # key -> (type, required)


@dataclass(frozen=True)
class Kind:
    """One kind of policy file (module docstring).

    build:  the factory of a fresh agent from the spec; None until `plugin` registers it.
    plugin: the module that registers `build` (torch, Ray or requests side), imported when first
            needed.
    keys:   the keys its files may hold beyond kind and description; None: the factory checks.
    fixed:  the fixed RLlib module that plays it in a curriculum, "scripted" (the rule of
            `scripted.RULES`), "search" (`search.search_actions` at the file's effort) or "net"
            (a frozen PommerNet); None: it cannot be one.
    """

    build: Factory | None
    plugin: str | None = None
    keys: KeySpec | None = field(default_factory=dict)
    fixed: str | None = None


def _scripted(agent: type) -> Factory:
    return lambda spec: agent()


KINDS: dict[str, Kind] = {
    **{kind: Kind(_scripted(rule.agent), fixed="scripted") for kind, rule in RULES.items()},
    "http": Kind(None, "rllib_pommer.agents.http_agent", None),  # it checks its own keys
    "search": Kind(SearchAgent.from_spec, keys={"depth": (int, False), "horizon": (int, False),
                                               "recall": (int, False)}, fixed="search"),
    "learned": Kind(None, "rllib_pommer.imitation.learned",
                    {"weights": (str, True), "greedy": (bool, False),
                     "temperature": (float, False)}, "net"),
    "finish": Kind(None, "rllib_pommer.agents.finisher",
                   {"policy": (str, True), "depth": (int, False), "horizon": (int, False),
                    "recall": (int, False), "margin": (float, False)}),
    "rllib_checkpoint": Kind(None, "rllib_pommer.runs.checkpoints",
                             {"checkpoint": (str, True), "greedy": (bool, False),
                              "temperature": (float, False), "module": (str, False)}, "net"),
}


def _check_params(path: Path, kind: str, params: Mapping[str, Any]) -> None:
    """Unknown keys and values of the wrong type (`toml_values.fits`) are errors, never ignored
    or coerced (a `greedy = "false"` would otherwise be true)."""
    valid = KINDS[kind].keys
    if valid is None:
        return
    for key, value in params.items():
        if key not in valid:
            raise ValueError(f"policy file {path}: unknown key {key!r} for kind {kind!r}; "
                             f"valid: {sorted(valid) or 'none'}")
        wanted = valid[key][0]
        if not fits(value, wanted):
            raise ValueError(f"policy file {path}: {key} must be a {wanted.__name__}, got "
                             f"{value!r}")
    missing = [key for key, (_, required) in valid.items() if required and key not in params]
    if missing:
        raise ValueError(f"policy file {path}: kind {kind!r} needs key {missing[0]!r}")


ACTING_KEYS = ("greedy", "temperature")  # how a learned policy acts, not which network it is


@dataclass(frozen=True)
class Acting:
    """How a learned policy file says to choose moves (and a radio net's words): the most
    likely one (`greedy`), or drawn from the softmax of the logits divided by `temperature`."""

    greedy: bool = False
    temperature: float = 1.0


def acting(spec: PolicySpec) -> Acting:
    """How the policy file `spec` acts: `greedy` (false unless said) and `temperature` (1.0
    unless said). A ValueError naming the file for a temperature that is not a positive finite
    number, or one beside `greedy = true`, which takes the most likely move at any
    temperature."""
    greedy = bool(spec.params.get("greedy", False))
    value = spec.params.get("temperature", 1.0)
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"policy file {spec.path}: temperature must be a positive number, "
                         f"got {value!r}")
    if greedy and "temperature" in spec.params:
        raise ValueError(f"policy file {spec.path}: temperature = {value!r} has no effect with "
                         f"greedy = true (the most likely move at any temperature); drop one "
                         f"of the two keys")
    return Acting(greedy, float(value))


def registered(kind: str) -> Kind:
    """The kind `kind` with its factory, importing the module that registers it the first time
    (the one way plugin code is loaded: by the name `KINDS` gives)."""
    if KINDS[kind].build is None:
        importlib.import_module(KINDS[kind].plugin)
    return KINDS[kind]


def register_kind(kind: str, factory: Factory) -> None:
    """Make policy files with `kind = "<kind>"` buildable: a plugin kind's factory (learned
    policies), or a new kind whose factory checks its own keys."""
    KINDS[kind] = replace(KINDS[kind], build=factory) if kind in KINDS else Kind(factory, keys=None)


def policies_dir() -> Path:
    return data_dir("policies")


def policy_names() -> list[str]:
    """Names of the policy files in `policies_dir()` (without filter suffixes)."""
    return sorted(path.stem for path in policies_dir().glob("*.toml"))


def _load_spec(path: Path, filters: tuple[str, ...]) -> PolicySpec:
    try:
        with path.open("rb") as f:
            data = tomllib.load(f)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"policy file {path}: invalid TOML ({exc})") from None
    kind = data.pop("kind", None)
    if not isinstance(kind, str) or kind not in KINDS:
        raise ValueError(f"policy file {path}: kind {kind!r} is not one of {sorted(KINDS)}")
    description = data.pop("description", "")
    if not isinstance(description, str):
        raise ValueError(f"policy file {path}: description must be a string")
    _check_params(path, kind, data)
    spec = PolicySpec(path.stem, kind, description, path, data, filters)
    if any(key in (KINDS[kind].keys or {}) for key in ACTING_KEYS):
        acting(spec)  # checked with the file, whoever reads it (arena, training, a curriculum)
    return spec


def _toml_value(value: Any) -> str:
    """`value` (a string, bool, integer or finite float) as TOML: JSON's string escapes are
    TOML's (non-ASCII kept as is, since TOML refuses the surrogate pairs JSON would write)."""
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int) or (isinstance(value, float) and math.isfinite(value)):
        return repr(value)
    raise ValueError(f"a policy file holds strings, booleans, integers and finite numbers, "
                     f"not {value!r}")


def write_policy_file(path: Path, kind: str, description: str, **params: Any) -> Path:
    """Write the policy file `path` as `resolve_policy` reads it: `kind`, the kind's keys
    `params` in the order given, then `description`. The keys are checked as the reader checks
    them, so a file written here always loads (a ValueError names what is wrong)."""
    if kind not in KINDS:
        raise ValueError(f"policy file {path}: kind {kind!r} is not one of {sorted(KINDS)}")
    _check_params(path, kind, params)
    lines = [f"kind = {_toml_value(kind)}"]
    lines += [f"{key} = {_toml_value(value)}" for key, value in params.items()]
    lines.append(f"description = {_toml_value(description)}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


class UnknownPolicy(ValueError):
    """No policy file goes by this name in `policies_dir()`."""


def looks_like_path(name_or_path: str | os.PathLike) -> bool:
    """Whether `resolve_policy` reads `name_or_path` as a path (a policy file, a run folder)
    rather than as a name in `policies_dir()`."""
    text = os.fspath(name_or_path)
    return text.endswith(".toml") or os.sep in text or "/" in text


def resolve_policy(name_or_path: str | os.PathLike) -> PolicySpec:
    """The spec of a policy name (optionally with a filter suffix) or of a policy file path."""
    if looks_like_path(name_or_path):
        path = Path(name_or_path)
        if path.is_dir():  # a PPO run, trial or checkpoint folder: play its learner
            return PolicySpec(path.name, "rllib_checkpoint", f"learner of {path}", path,
                              {"checkpoint": str(path.resolve())})
        folder, _, module = os.fspath(name_or_path).rpartition("@")
        if folder and Path(folder).is_dir():  # DIR@MODULE: another module of it (a snapshot)
            return PolicySpec(f"{Path(folder).name}@{module}", "rllib_checkpoint",
                              f"module {module} of {folder}", Path(folder),
                              {"checkpoint": str(Path(folder).resolve()), "module": module})
        if not path.is_file():
            raise ValueError(f"policy file {path} does not exist")
        return _load_spec(path, ())
    name = str(name_or_path)
    folder = policies_dir()
    stems = [(name, False)]
    if name.endswith(WORDS_SUFFIX):
        stems.append((name[: -len(WORDS_SUFFIX)], True))
    for stem, words in stems:
        candidates = [(stem, ())] + [
            (stem[: -len(suffix)], filters)
            for suffix, filters in FILTER_SUFFIXES.items()
            if stem.endswith(suffix)
        ]
        for base, filters in candidates:
            path = folder / f"{base}.toml"
            if base and path.is_file():
                return replace(_load_spec(path, filters), words=words)
    raise UnknownPolicy(
        f"unknown policy {name!r}; valid: {policy_names()} (in {folder}), each optionally "
        f"suffixed with {sorted(FILTER_SUFFIXES)} and then {WORDS_SUFFIX!r}, or a path to a "
        ".toml policy file"
    )


def _known_filters(filters: Iterable[str]) -> set[str]:
    """The set of filter names `filters` (one name or several), or a ValueError naming those
    that are not in `FILTERS`."""
    wanted = {filters} if isinstance(filters, str) else set(filters)
    unknown = sorted(wanted - set(FILTERS))
    if unknown:
        raise ValueError(f"unknown filter(s) {unknown}; valid: {list(FILTERS)}")
    return wanted


def with_filters(agent: Agent, filters: Iterable[str]) -> Agent:
    """`agent` inside the wrappers of the filters named, stacked in the order of `FILTERS`
    whatever the order they are named in (the one place the stack is built)."""
    wanted = _known_filters(filters)
    for filter_name, wrapper in FILTERS.items():
        if filter_name in wanted:
            agent = wrapper(agent)
    return agent


def switched_on(switches: Mapping[str, bool]) -> tuple[str, ...]:
    """The filters an episode's switches turn on (`FILTER_SWITCHES`: switch name -> on), in
    stacking order; a ValueError names a switch that no filter has."""
    unknown = sorted(set(switches) - set(FILTER_SWITCHES.values()))
    if unknown:
        raise ValueError(f"unknown filter switch(es) {unknown}; valid: "
                         f"{list(FILTER_SWITCHES.values())}")
    return tuple(name for name, switch in FILTER_SWITCHES.items() if switches.get(switch))


def make_agent(name_or_path: str | os.PathLike, filters: Iterable[str] = ()) -> Agent:
    """A fresh agent for a policy, wrapped in its name's filters and in `filters`, and in a
    `Speaker` (outermost) if its name ends in `_words`."""
    extra = _known_filters(filters)
    spec = resolve_policy(name_or_path)
    agent = with_filters(registered(spec.kind).build(spec), set(spec.filters) | extra)
    return Speaker(agent) if spec.words else agent
