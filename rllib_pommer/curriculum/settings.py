"""The settings of a PPO run, typed and written once: what PPO computes, and where the run goes.

Plain dataclasses that import neither Ray nor torch, so that `python -m rllib_pommer.train` builds
its options from them before anything heavy loads (`util/cli_options.py`), a curriculum file is
checked against them without Ray, and `bench learn` hands the plain-torch baseline
(`imitation/speed.py`) the same minibatch and clip as the real learner's.

`PPOSettings` are the values `rl/config.build_config` hands RLlib; a curriculum's `[ppo]` table may
override the fields marked as options (our choices, argued in rl/config.py), never the paper's
(entropy 0, clip 0.01, minibatch 128). `LeagueSettings` are a curriculum's `[league]` table, the
self-play snapshots (rl/league.py). `RunSettings` are one `train` command's.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import dataclass, field
from pathlib import Path

from .matchmaking import MATCHMAKING


def _option(default, low=None, high=None, key: str | None = None,
            choices: tuple[str, ...] | None = None):
    """A field a curriculum's table may set under `key` (default: the field's name), with
    values in (low, high], or one of `choices`; integers must be positive."""
    return field(default=default, metadata={"option": key, "range": (low, high),
                                            "choices": choices})


class TableSettings:
    """Settings a curriculum's table may set, field by field (`_option` fields)."""

    @classmethod
    def options(cls) -> dict[str, tuple[type, float | None, float | None,
                                        tuple[str, ...] | None]]:
        """{key in the table: (type, low, high, choices)} of every overridable field."""
        hints = typing.get_type_hints(cls)
        return {f.metadata["option"] or f.name: (hints[f.name], *f.metadata["range"],
                                                 f.metadata["choices"])
                for f in dataclasses.fields(cls) if "option" in f.metadata}

    @classmethod
    def from_options(cls, table: typing.Mapping[str, typing.Any]):
        """The defaults with a table's (already checked) values in place."""
        names = {f.metadata["option"] or f.name: f.name
                 for f in dataclasses.fields(cls) if "option" in f.metadata}
        return cls(**{names[key]: value for key, value in table.items()})


@dataclass(frozen=True)
class PPOSettings(TableSettings):
    """Every PPO setting of a run; the defaults are the ones campaign runs were started with."""

    # Options of a curriculum's [ppo] table.
    lr: float = _option(1e-4, low=0)
    gamma: float = _option(0.999, low=0, high=1)
    lambda_: float = _option(0.95, low=0, high=1, key="lambda")
    num_epochs: int = _option(4)
    train_batch_size: int = _option(4000)  # env steps per iteration (RLlib: per learner)
    num_envs_per_env_runner: int = _option(8)
    vf_loss_coeff: float = _option(1.0, low=0)
    checkpoint_every: int = _option(5)  # iterations between Tune checkpoints
    # The dual clip's bound on the ratio of rows with a negative advantage (rl/learner.py);
    # inf: none, PPO as the paper ran it.
    dual_clip: float = _option(math.inf, low=1)
    # Kickstarting (rl/teacher.py): a policy whose moves on the learner's steps pull pi, with
    # this weight on their cross-entropy; "": none.
    teacher: str = _option("")
    teacher_weight: float = _option(0.5, low=0)
    # Fixed: the paper's (entropy, clip, minibatch) and ours (no KL penalty, gradient clip).
    entropy_coeff: float = 0.0
    clip_param: float = 0.01
    minibatch_size: int = 128
    use_kl_loss: bool = False
    grad_clip: float = 10.0


@dataclass(frozen=True)
class LeagueSettings(TableSettings):
    """Self-play snapshot slots and the gate that fills them (rl/league.py), and how the
    league's members are matched with the learner (curriculum/matchmaking.py)."""

    slots: int = _option(4, high=16)  # frozen modules snapshot_0 .. snapshot_{slots - 1}
    gate_games: int = _option(400)  # league games per block of the gate
    gate_win: float = _option(0.7, low=0, high=1)  # a block's win rate that adds a snapshot
    # "uniform": members take turns in order; "prioritized": by how often the learner fails
    # to beat each, max(floor, (1 - win rate) ** power), records halving every `halflife`
    # games against the member.
    matchmaking: str = _option("uniform", choices=MATCHMAKING)
    priority_power: float = _option(2.0, low=0)
    priority_floor: float = _option(0.1, low=0, high=1)
    priority_halflife: int = _option(100)
    # An exploiter (rl/league.py): a second trained module that plays the learner alone, joins
    # its league, and whose pi fills the next snapshot slot when a block of
    # `exploiter_gate_games` of its games is won at `exploiter_gate_win` or more; it then starts
    # again from the learner's weights.
    exploiter: bool = _option(False)
    exploiter_gate_games: int = _option(300)
    exploiter_gate_win: float = _option(0.5, low=0, high=1)

    @property
    def prioritized(self) -> bool:
        return self.matchmaking == "prioritized"

    def slot_ids(self) -> list[str]:
        return [f"snapshot_{i}" for i in range(self.slots)]


@dataclass(frozen=True)
class RunSettings:
    """One `python -m rllib_pommer.train` run; each field is one option of the command."""

    curriculum: str | None = None  # None: the run's own on resume, else "quick"
    out: Path | None = None  # default runs/<curriculum name>
    resume: bool = False
    address: str | None = None  # None: a Ray instance of our own on this machine
    pi_weights: Path | None = None  # None: the curriculum's
    num_env_runners: int = 0  # 0: sample in the learner's process, one run per core
    seed: int = 0
    num_cpus: int = 2  # of our own Ray instance
    torch_threads: int = 1  # the learner's (and the driver's): 2 with 2 env runners on 2 cores
    # Learner actors updating data-parallel (rl/learner.py); 0: one learner in the algorithm's
    # process. Each holds these GPUs and CPUs (RLlib: 0 learners put them on that process).
    num_learners: int = 0
    num_gpus_per_learner: float = 0.0
    num_cpus_per_learner: float = 1.0

    @property
    def main_process_cpus(self) -> float:
        """Ray CPUs of the algorithm's process: one, or the learner's own where it holds the
        learner and asks for more (RLlib's bundle takes the larger)."""
        return 1.0 if self.num_learners else max(1.0, self.num_cpus_per_learner)

    @property
    def learner_cpus(self) -> float:
        """Ray CPUs of the learner actors together."""
        return self.num_learners * self.num_cpus_per_learner

    @property
    def gpus(self) -> float:
        """GPUs the run asks for: each learner's, or the one learner's in the algorithm's
        process."""
        return max(self.num_learners, 1) * self.num_gpus_per_learner

    def __post_init__(self):
        for name, low in (("num_env_runners", 0), ("num_cpus", 1), ("torch_threads", 1),
                          ("seed", 0), ("num_learners", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"--{name.replace('_', '-')} must be {low} or more, "
                                 f"got {value!r}")
        for name, low in (("num_gpus_per_learner", 0.0), ("num_cpus_per_learner", 0.0)):
            _check_quantity(name, getattr(self, name), low)
        if self.num_learners and not (self.num_cpus_per_learner or self.num_gpus_per_learner):
            raise ValueError(f"--num-learners {self.num_learners} with --num-cpus-per-learner 0 "
                             f"and --num-gpus-per-learner 0: a learner needs a CPU or a GPU")
        if self.address is None:
            self._check_own_cpus()
        if self.address is None and self.torch_threads > self.num_cpus:
            raise ValueError(f"--torch-threads {self.torch_threads} exceeds --num-cpus "
                             f"{self.num_cpus}: threads beyond the CPUs only wait on each other")

    def _check_own_cpus(self) -> None:
        """Refuse a layout our own Ray instance (`--num-cpus`) cannot place: Tune would wait
        for the CPUs for ever. The algorithm's process and the learners take theirs first;
        remote env runners share what is left (launch/training.cpus_per_env_runner)."""
        if not self.num_learners and self.main_process_cpus == 1:
            if self.num_env_runners and self.num_cpus < 2:
                raise ValueError(f"--num-env-runners {self.num_env_runners} needs --num-cpus 2 "
                                 f"or more: the learner's process takes one Ray CPU and each "
                                 f"runner needs a share of another (with {self.num_cpus}, Tune "
                                 f"would wait for CPUs forever)")
            return
        fixed = self.main_process_cpus + self.learner_cpus
        asks = (f"1 for the algorithm's process and {self.learner_cpus:g} for --num-learners "
                f"{self.num_learners} x --num-cpus-per-learner {self.num_cpus_per_learner:g}"
                if self.num_learners else
                f"{fixed:g} for the learner's process (--num-cpus-per-learner "
                f"{self.num_cpus_per_learner:g})")
        if fixed > self.num_cpus + 1e-9:
            raise ValueError(f"the run asks for {fixed:g} Ray CPUs ({asks}) but --num-cpus is "
                             f"{self.num_cpus} (Tune would wait for CPUs forever): pass "
                             f"--num-cpus {math.ceil(fixed - 1e-9)} or more, or ask for fewer "
                             f"learner CPUs")
        if self.num_env_runners and fixed > self.num_cpus - 1e-9:
            raise ValueError(f"--num-env-runners {self.num_env_runners} needs a share of a CPU "
                             f"beside the {fixed:g} the run's learners take ({asks}), and "
                             f"--num-cpus {self.num_cpus} leaves none (Tune would wait for "
                             f"CPUs forever): pass --num-cpus {math.floor(fixed + 1e-9) + 1} or "
                             f"more, or --num-env-runners 0")


def _check_quantity(name: str, value, low: float) -> None:
    """A Ray resource quantity: a number of at least `low`, below 1 or whole (Ray refuses
    1.5 GPUs)."""
    option = f"--{name.replace('_', '-')}"
    if isinstance(value, bool) or not isinstance(value, int | float) or not value >= low \
            or math.isinf(value):
        raise ValueError(f"{option} must be a number of {low:g} or more, got {value!r}")
    if value > 1 and value != int(value):
        raise ValueError(f"{option} must be below 1 or a whole number (Ray's rule for "
                         f"resources), got {value!r}")
