"""Curricula as data: TOML files in the top-level `curriculum/` folder, checked on load.

A file names the run, optionally the imitation weights pi starts from (default: the shipped
`policies/imitation/pi.pt`, wherever the file lies), PPO options, defaults for every stage, and
the stages in order::

    name = "paper"
    game = "team"                                # optional; "radio": TeamRadio
    memory = false                               # optional; true: the memory planes too
    pi_weights = "../policies/imitation/pi.pt"   # optional; relative to this file
    [ppo]
    train_batch_size = 4000
    [defaults]
    teammate = "suicide"
    [[stage]]
    name = "warmup"
    opponent = "simple"
    episodes = 10000
    freeze_pi = true

A stage lasts `episodes` lifetime episodes (counted over all env runners). Policies are names from
`policies/` (never paths: each name is an RLlib module id) whose kind has a fixed RLlib module
(`agents/registry.KINDS`: scripted kinds, or frozen learned / RLlib-checkpoint policies, whose files
are read and checked as the arena reads them); a teammate may also be `"learner"`, the trained
policy itself, so both seats of its team learn as one policy (the paper's recipe keeps a
SuicideTeammate beside a lone learner), and an opponent a list of policies, a league that takes
turns by episodes (`opponent = ["simple", "static", "ppo_cautious"]`; curriculum/mapping.py says
how), and names may carry the registry's filter suffixes (`simple_action`: SimpleAgent behind the
action filter). A `[league]` table (`slots`, `gate_games`, `gate_win`) adds frozen self-play
snapshots of the learner, which join the league of every stage marked `self_play = true`
(rl/league.py; a `[league]` table needs at least one), and may ask for `matchmaking = "prioritized"`
(with `priority_power`, `priority_floor`, `priority_halflife`): the league's members then meet the
learner by how often it fails to beat them (curriculum/matchmaking.py) instead of in turn. `game =
"radio"` trains in TeamRadio: the learner's action is [move, word, word] and it hears its teammate's
words (rl/rl_module.py); scripted and Team policies in the other seats play moves, which send no
words, so `teammate = "learner"` is how the words reach a listener that learns; self-play snapshots
are Team nets, so a radio curriculum has no [league]. Every error names the file, the key and the
valid choices, so a typo fails before Ray starts: this module imports neither Ray nor torch
(tests/test_layering.py checks a whole load in a fresh interpreter).
"""

from __future__ import annotations

import json
import re
import sys
import typing
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from ..agents.registry import (
    KINDS,
    WORDS_SUFFIX,
    UnknownPolicy,
    looks_like_path,
    policies_dir,
    policy_names,
    resolve_policy,
)
from ..game.constants import TEAM_GAMES, TEAM_PRESET
from ..game.rewards import REWARD_MODES
from ..util.digest import file_sha256
from ..util.shipped import data_dir
from ..util.toml_values import fits
from .names import EXPLOITER, LEARNER
from .settings import LeagueSettings, PPOSettings

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

TOP_KEYS = ("name", "description", "game", "pi_weights", "vf_weights", "max_steps", "memory",
            "ppo", "league", "defaults", "stage")


@dataclass(frozen=True)
class Stage:
    """One phase of a curriculum: who plays, for how many episodes, with which reward and
    filters, and whether pi is frozen. `opponent` is a policy name, or a league of them that
    take turns (curriculum/mapping.py)."""
    name: str
    opponent: str | tuple[str, ...]
    episodes: int
    teammate: str = "suicide"
    reward: str = "shaped"
    action_filter: float = 0.3
    jitter: float = 0.1
    freeze_pi: bool = False
    self_play: bool = False  # the league's filled snapshot slots join this stage's opponents

    @property
    def opponents(self) -> tuple[str, ...]:
        return (self.opponent,) if isinstance(self.opponent, str) else self.opponent


STAGE_KEYS = tuple(f.name for f in fields(Stage))


@dataclass(frozen=True)
class Curriculum:
    """A training schedule as loaded and checked from its TOML file."""
    name: str
    path: Path
    stages: tuple[Stage, ...]
    pi_weights: Path
    max_steps: int
    ppo: PPOSettings
    league: LeagueSettings | None = None  # self-play snapshot slots and their gate
    description: str = ""
    vf_weights: Path | None = None  # a value network's state_dict; None: vf starts at random
    game: str = "team"  # `TEAM_GAMES`: "team", or "radio" (TeamRadio: the learner also speaks)
    memory: bool = False  # the learner reads the memory planes too (imitation/recall.py)

    @property
    def total_episodes(self) -> int:
        return sum(stage.episodes for stage in self.stages)

    def stage_at(self, episodes: int) -> int:
        """Index of the stage in force after `episodes` lifetime episodes (the last one at the
        end, so a run that overshoots keeps its final setting)."""
        last = len(self.stages) - 1
        return next((i for i in range(last) if episodes < self.stage_end(i)), last)

    def stage_end(self, index: int) -> int:
        """The lifetime episode count at which stage `index` ends."""
        return sum(stage.episodes for stage in self.stages[:index + 1])

    def policies(self) -> list[str]:
        """Every fixed policy some stage plays, in first-use order (one fixed module each; a
        "learner" teammate is the trained module)."""
        names: list[str] = []
        for stage in self.stages:
            for name in (stage.teammate, *stage.opponents):
                if name not in names and name != LEARNER:
                    names.append(name)
        return names

    def league_members(self) -> list[str]:
        """Everyone the matchmaking book keeps a record against (rl/league.py): every stage's
        opponents in first-use order, then the exploiter if there is one, then the snapshot
        slots."""
        names: list[str] = []
        for stage in self.stages:
            names += [name for name in stage.opponents if name not in names]
        if self.league is None:
            return names
        return names + ([EXPLOITER] if self.league.exploiter else []) + self.league.slot_ids()


def curriculum_dir() -> Path:
    """The shipped curricula: the repository's `curriculum/` (a wheel's copy of it), or the
    folder named by RLLIB_POMMER_CURRICULA, found from any working directory (util/shipped.py)."""
    return data_dir("curriculum")


def curriculum_names() -> list[str]:
    return sorted(path.stem for path in curriculum_dir().glob("*.toml"))


def find_curriculum(name_or_path: str | Path) -> Path:
    path = Path(name_or_path)
    if path.is_file():
        return path.resolve()
    named = curriculum_dir() / f"{name_or_path}.toml"
    if named.is_file():
        return named
    raise ValueError(f"curriculum {str(name_or_path)!r} not found; valid names: "
                     f"{curriculum_names()} (in {curriculum_dir()}), or a path to a .toml file")


def _check_keys(where: str, table: dict, valid) -> None:
    for key in table:
        if key not in valid:
            raise ValueError(f"{where}: unknown key {key!r}; valid keys: {sorted(valid)}")


def _check_type(where: str, key: str, value: Any, kind: type, positive: bool = False) -> None:
    """A value of the key's type (`toml_values.fits`), positive where asked."""
    if not fits(value, kind) or (positive and not value > 0):
        wanted = ("a positive integer" if positive else
                  {bool: "true or false", int: "an integer", float: "a number",
                   str: "a string"}[kind])
        raise ValueError(f"{where}: {key} must be {wanted}, got {value!r}")


def _check_options(where: str, table: dict, options: dict) -> None:
    """A table of bounded options (`PPOSettings.options()`, `LeagueSettings.options()`)."""
    _check_keys(where, table, options)
    for key, value in table.items():
        kind, low, high, choices = options[key]
        _check_type(where, key, value, kind, positive=kind is int)
        if (low is not None and not value > low) or (high is not None and not value <= high):
            raise ValueError(f"{where}: {key} must be {_bounds(low, high)}, got {value!r}")
        if choices is not None and value not in choices:
            raise ValueError(f"{where}: {key} {value!r} is not one of {list(choices)}")


def _bounds(low: float | None, high: float | None) -> str:
    """The range (low, high] in words; a None end is open."""
    return f"at most {high}" if low is None else f"in ({low}, {'inf' if high is None else high}]"


def _check_policy(where: str, name: Any) -> None:
    """A policy a fixed module can play, named as RLlib names the module: a name in
    `policies_dir()`, not a path (RLlib refuses a module id with a slash)."""
    if looks_like_path(name):
        raise ValueError(f"{where}: {name!r} is a path; a curriculum names its policies by their "
                         f"names in {policies_dir()} (each one names an RLlib module): put the "
                         f"policy file there and write its name, e.g. {Path(name).stem!r}")
    try:
        spec = resolve_policy(name)
    except UnknownPolicy:
        raise ValueError(f"{where}: unknown policy {name!r}; valid: {policy_names()}") from None
    except ValueError as exc:  # a policy file that does not hold a policy
        raise ValueError(f"{where}: {exc}") from None
    if spec.words:
        raise ValueError(f"{where}: policy {name!r} speaks (its {WORDS_SUFFIX!r} suffix), which "
                         f"the fixed RLlib modules do not: name it without {WORDS_SUFFIX!r} "
                         f"(silent) or use the learner as teammate")
    if KINDS[spec.kind].fixed is None:
        fixed = [kind for kind, entry in KINDS.items() if entry.fixed]
        raise ValueError(f"{where}: policy {name!r} cannot be a fixed module (kind {spec.kind!r});"
                         f" valid: {policy_names()} (with filter suffixes too), of kinds {fixed}")


def _opponent(where: str, value: Any) -> str | tuple[str, ...]:
    """A stage's opponent: one policy name, or a list of distinct ones (a league, kept as a
    tuple; a list of one is that name)."""
    names = value if isinstance(value, list) else [value]
    if not names or not all(isinstance(name, str) for name in names) \
            or len(set(names)) != len(names):
        raise ValueError(f"{where}: opponent must be a policy name or a list of distinct policy "
                         f"names, got {value!r}")
    for name in names:
        _check_policy(f"{where} key 'opponent'", name)
    return names[0] if len(names) == 1 else tuple(names)


def _stage(where: str, table: dict) -> Stage:
    _check_keys(where, table, STAGE_KEYS)
    for key in ("name", "opponent", "episodes"):
        if key not in table:
            raise ValueError(f"{where}: missing key {key!r}")
    for key, kind in typing.get_type_hints(Stage).items():
        if key in table and key != "opponent":
            _check_type(where, key, table[key], kind, positive=key == "episodes")
    stage = Stage(**{**table, "opponent": _opponent(where, table["opponent"])})
    if stage.reward not in REWARD_MODES:
        raise ValueError(f"{where}: reward {stage.reward!r} is not one of {list(REWARD_MODES)}")
    for key in ("action_filter", "jitter"):
        value = getattr(stage, key)
        if not isinstance(value, (int, float)) or not 0 <= value <= 1:
            raise ValueError(f"{where}: {key} must be a probability in [0, 1], got {value!r}")
    if stage.teammate != LEARNER:
        _check_policy(f"{where} key 'teammate' (a policy, or {LEARNER!r}: the trained one)",
                      stage.teammate)
    return stage


def _check_self_play(where: str, stages: tuple[Stage, ...], league: bool, game: str) -> None:
    """Self-play snapshots come with the stages they play in: a stage marked `self_play` needs
    the `[league]` table that makes the snapshots, which are Team nets (the Team game only), and
    a `[league]` table needs a stage to play its snapshots in (else they are built and never
    played)."""
    playing = [i + 1 for i, stage in enumerate(stages) if stage.self_play]
    if playing and game != "team":
        raise ValueError(f"{where} stage {playing[0]}: self_play (snapshots of the learner, Team "
                         f"nets) plays the Team game only, not game {game!r}")
    if playing and not league:
        raise ValueError(f"{where} stage {playing[0]}: self_play needs a [league] table "
                         f"(slots, gate_games, gate_win)")
    if league and not playing:
        raise ValueError(f"{where}: no stage has self_play = true, so the [league] table's "
                         f"snapshots would never play; mark the stages they join, or drop "
                         f"[league]")


def load_curriculum(name_or_path: str | Path) -> Curriculum:
    """The curriculum of a name in `curriculum/` or of a file path, validated."""
    path = find_curriculum(name_or_path)
    try:
        with path.open("rb") as f:
            data = tomllib.load(f)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"curriculum file {path}: invalid TOML ({exc})") from None
    where = f"curriculum file {path}"
    _check_keys(where, data, TOP_KEYS)
    for key, kind in (("name", str), ("description", str), ("game", str), ("pi_weights", str),
                      ("vf_weights", str)):
        if key in data:
            _check_type(where, key, data[key], kind)
    if data.get("game", "team") not in TEAM_GAMES:
        raise ValueError(f"{where}: game {data['game']!r} is not one of {list(TEAM_GAMES)}")
    if "max_steps" in data:
        _check_type(where, "max_steps", data["max_steps"], int, positive=True)
    if "memory" in data:
        _check_type(where, "memory", data["memory"], bool)
    ppo = data.get("ppo", {})
    _check_options(f"{where} [ppo]", ppo, PPOSettings.options())
    if ppo.get("teacher"):  # kickstarting (rl/teacher.py): a policy the arena plays
        _check_policy(f"{where} [ppo] teacher", ppo["teacher"])
    league = data.get("league")
    if league is not None:
        _check_options(f"{where} [league]", league, LeagueSettings.options())
        if data.get("game", "team") != "team":
            raise ValueError(f"{where}: a [league] (self-play snapshots) plays the Team game "
                             f"only, not game {data['game']!r}")
    defaults = data.get("defaults", {})
    _check_keys(f"{where} [defaults]", defaults, set(STAGE_KEYS) - {"name", "episodes"})
    tables = data.get("stage", [])
    if not tables:
        raise ValueError(f"{where}: no [[stage]] tables")
    stages = tuple(_stage(f"{where} stage {i + 1}", {**defaults, **table})
                   for i, table in enumerate(tables))
    _check_self_play(where, stages, league is not None, data.get("game", "team"))
    return Curriculum(
        name=data.get("name", path.stem),
        path=path,
        stages=stages,
        pi_weights=(path.parent / data["pi_weights"] if "pi_weights" in data
                    else policies_dir() / "imitation" / "pi.pt").resolve(),
        max_steps=data.get("max_steps", TEAM_PRESET.max_steps),
        ppo=PPOSettings.from_options(ppo),
        league=None if league is None else LeagueSettings.from_options(league),
        description=data.get("description", ""),
        vf_weights=(path.parent / data["vf_weights"]).resolve() if data.get("vf_weights")
        else None,
        game=data.get("game", "team"),
        memory=data.get("memory", False),
    )


# The curriculum a run trains on, noted in its folder when it starts (`record_run_curriculum`):
# a shipped one by its name (the run may move to another clone), another by its file's path.
RUN_CURRICULUM_FILE = "curriculum.json"
PI_START_KEY = "pi_start_sha256"  # in it: the digest of the weights the run began with
DEFAULT_CURRICULUM = "quick"
# How a trial's params.json names its curriculum (the repr of the curriculum callback's partial
# in the config of runs started before runs noted theirs): such a run is read from there.
CURRICULUM_IN_PARAMS = re.compile(r"Curriculum\(name='([^']+)', path=\w*Path\('([^']+)'\)")


def shipped_name(path: Path) -> str | None:
    """The name of a shipped curriculum file (here, or in another clone's `curriculum/`: a
    packed run moves), None for any other file."""
    here = (curriculum_dir() / f"{path.stem}.toml").resolve()
    if Path(path).resolve() == here or (path.parent.name == "curriculum" and here.is_file()):
        return path.stem
    return None


def describe(curriculum: Curriculum) -> str:
    """A curriculum as a user names it: its shipped name, or its file."""
    name = shipped_name(curriculum.path)
    return repr(name) if name else f"{curriculum.name!r} ({curriculum.path})"


def curriculum_ref(curriculum: Curriculum) -> str:
    """The curriculum as a run's data names it, for `load_curriculum` to read again: its
    shipped name (the run may move to another clone), else its file's absolute path."""
    return shipped_name(curriculum.path) or str(curriculum.path.resolve())


def record_run_curriculum(run: Path, curriculum: Curriculum, pi_start: Path | None = None) -> None:
    """Note in the run folder which curriculum the run trains on and, when it starts from a
    weights file (`pi_start`), that file's SHA-256: the file may be replaced later (a policy
    shipped again under its name), the digest still proves which weights the run began with.
    A resume (no `pi_start`) keeps the digest noted at the start."""
    Path(run).mkdir(parents=True, exist_ok=True)
    digest = file_sha256(pi_start) if pi_start else run_start_digest(run)
    (Path(run) / RUN_CURRICULUM_FILE).write_text(json.dumps(
        {"curriculum": curriculum_ref(curriculum), "name": curriculum.name}
        | ({PI_START_KEY: digest} if digest else {})) + "\n")


def run_start_digest(run: Path) -> str | None:
    """The SHA-256 of the weights file the run's pi started from, as its `RUN_CURRICULUM_FILE`
    notes it (None for runs started before runs noted it, or without one)."""
    note = Path(run) / RUN_CURRICULUM_FILE
    try:
        digest = json.loads(note.read_text()).get(PI_START_KEY) if note.is_file() else None
    except (ValueError, AttributeError) as exc:
        raise ValueError(f"{note}: unreadable ({type(exc).__name__}: {exc})") from None
    return digest if isinstance(digest, str) else None


def _recorded(run: Path) -> tuple[str, str, str] | None:
    """(shipped name or file path, curriculum name, where it was read) of the run's curriculum,
    if noted."""
    note = Path(run) / RUN_CURRICULUM_FILE
    if note.is_file():
        try:
            data = json.loads(note.read_text())
            return str(data["curriculum"]), str(data["name"]), str(note)
        except (ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"{note}: unreadable ({type(exc).__name__}: {exc}); resume with "
                             f"--curriculum and the run's own curriculum") from None
    for params in sorted(Path(run).resolve().glob("*/params.json")):
        found = CURRICULUM_IN_PARAMS.search(params.read_text())
        if found:
            path = Path(found.group(2))
            return shipped_name(path) or str(path), found.group(1), str(params)
    return None


def _gone(run: Path, path: str, where: str) -> ValueError:
    return ValueError(f"the run in {run} trained on the curriculum file {path} (noted in "
                      f"{where}), which is gone; put it back, or give its new place with "
                      f"--curriculum")


def run_curriculum(run: Path) -> Curriculum | None:
    """The curriculum the run in `run` trained on (its `RUN_CURRICULUM_FILE`, else its trials'
    params.json); None if neither names one. A curriculum file that is gone is a ValueError
    naming it."""
    recorded = _recorded(run)
    if recorded is None:
        return None
    name_or_path, _, where = recorded
    if Path(name_or_path).is_absolute() and not Path(name_or_path).is_file():
        raise _gone(run, name_or_path, where)
    return load_curriculum(name_or_path)


def resume_curriculum(run: Path, given: Curriculum | None) -> Curriculum:
    """The curriculum a resume of the run in `run` trains on: its own, also when `given` (the
    --curriculum option) is None. Another one is refused, naming both; a run whose curriculum
    file moved takes `given` in its place when the names agree."""
    recorded = _recorded(run)
    if recorded is None:
        if given is None:
            raise ValueError(f"--resume: the run in {run} names no curriculum (no "
                             f"{RUN_CURRICULUM_FILE}, no params.json); pass --curriculum")
        return given
    name_or_path, name, where = recorded
    if Path(name_or_path).is_absolute() and not Path(name_or_path).is_file():
        if given is not None and given.name == name:
            return given
        raise _gone(run, name_or_path, where)
    own = load_curriculum(name_or_path)
    if given is not None and given.path.resolve() != own.path.resolve():
        raise ValueError(f"--resume: the run in {run} trains on curriculum {describe(own)}, "
                         f"not {describe(given)}; resume it without --curriculum, or start "
                         f"the other curriculum in another --out")
    return own
