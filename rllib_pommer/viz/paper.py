"""The paper's Tables 2 and 3 (Meisheri et al. 2019), from its LaTeX tables (tests/reference/),
and what its text says its Fig. 3 shows.

Each cell is (win, loss, tie) of the row's team in 1000 games, by opponent and by variant; None
where the paper has "-". One typo is corrected: Table 3, SimpleAgent_NoBomb_action, PPO_action
reads "016" for the loss rate; 0.16 makes the row sum to 1.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .matches import VARIANTS

Cell = tuple[float, float, float] | None

# Our policy name of each opponent row of the paper.
PAPER_OPPONENTS = {
    "static": "StaticAgent",
    "simple_nobomb": "SimpleAgent_NoBomb",
    "simple": "SimpleAgent",
    "simple_nobomb_action": "SimpleAgent_NoBomb_action",
    "simple_action": "SimpleAgent_action",
    "ppo_cautious": "PPO_agent_Cautious",
    "imitation": "Imitation_Vanilla",
    "skynet": "Skynet",
}


def _row(*cells: Cell) -> dict[str, Cell]:
    return dict(zip(VARIANTS, cells, strict=True))


# Our team policy name -> (table title, {opponent policy name -> variant -> cell}).
PAPER_TABLES: dict[str, tuple[str, dict[str, dict[str, Cell]]]] = {
    "imitation": ("Table 2: Imitation team", {
        "static": _row((0.111, 0.156, 0.733), (0.458, 0.34, 0.201), (0.271, 0.009, 0.72),
                       (0.824, 0.032, 0.144)),
        "simple_nobomb": _row((0.355, 0.416, 0.299), (0.379, 0.507, 0.114),
                              (0.615, 0.109, 0.275), (0.753, 0.115, 0.131)),
        "simple": _row((0.331, 0.418, 0.251), (0.361, 0.498, 0.141), (0.603, 0.099, 0.297),
                       (0.756, 0.126, 0.118)),
        "simple_nobomb_action": _row((0.218, 0.607, 0.175), (0.242, 0.663, 0.095),
                                     (0.493, 0.176, 0.331), (0.63, 0.227, 0.143)),
        "simple_action": _row((0.2, 0.618, 0.181), (0.243, 0.665, 0.091), (0.503, 0.167, 0.33),
                              (0.64, 0.206, 0.154)),
        "ppo_cautious": _row((0.011, 0.149, 0.84), (0.048, 0.709, 0.242), (0.024, 0.019, 0.957),
                             (0.268, 0.226, 0.506)),
    }),
    "ppo": ("Table 3: PPO team", {
        "static": _row((0.179, 0.138, 0.681), (0.614, 0.253, 0.132), (0.347, 0.003, 0.65),
                       (0.904, 0.023, 0.073)),
        "simple_nobomb": _row((0.373, 0.366, 0.260), (0.425, 0.446, 0.128),
                              (0.583, 0.081, 0.335), (0.778, 0.111, 0.111)),
        "simple": _row((0.347, 0.379, 0.273), (0.426, 0.45, 0.123), (0.622, 0.079, 0.298),
                       (0.778, 0.088, 0.135)),
        "simple_nobomb_action": _row((0.230, 0.586, 0.183), (0.271, 0.641, 0.086),
                                     (0.507, 0.16, 0.333), (0.681, 0.19, 0.129)),
        "simple_action": _row((0.260, 0.537, 0.202), (0.282, 0.615, 0.101),
                              (0.521, 0.167, 0.312), (0.672, 0.186, 0.142)),
        "ppo_cautious": _row((0.007, 0.138, 0.855), (0.067, 0.69, 0.239), (0.026, 0.011, 0.963),
                             (0.313, 0.126, 0.423)),
        "imitation": _row((0.145, 0.108, 0.747), (0.411, 0.388, 0.201), (0.243, 0.011, 0.746),
                          (0.713, 0.099, 0.188)),
        "skynet": _row(None, None, None, (0.451, 0.126, 0.423)),
    }),
}


@dataclass(frozen=True)
class Fig3Claim:
    """One reading of the paper's Fig. 3, in our words, and where our runs test it: the rows of
    the phase table (`tables.phase_progress_table`) of `runs` in `phases`; `note` says what the
    rows need said beside them."""

    reading: str
    phases: tuple[str, ...]
    runs: tuple[str, ...]
    note: str = ""


# What the paper reads in its Fig. 3 (four runs of 100,000 games: the curriculum with shaping,
# the cautious agent, the curriculum without shaping, shaping without a curriculum), each with
# the runs and phases of ours that test it (their curricula: curriculum/*.toml).
FIG3_CLAIMS = (
    Fig3Claim("After training, the reward is above the imitation policy's, which the value "
              "warm-up measures (the policy is frozen there).", ("value_warmup", "simple"),
              ("paper",)),
    Fig3Claim("The cautious agent's reward first falls, then settles: its teammate is active, "
              "so credit is harder to assign.", ("value_warmup", "simple"), ("cautious",)),
    Fig3Claim("Without a curriculum (shaping, SimpleAgent from the start, teammate removed) "
              "learning is slow; both curriculum runs progress much faster.", ("simple",),
              ("no_curriculum", "paper", "no_shaping", "cautious"),
              "the paper's text names its blue and orange curves, but blue is the cautious run, "
              "which has no curriculum either; `paper` and `no_shaping` are the curriculum runs"),
    Fig3Claim("Without shaping (a tie pays -1 like a loss) learning is hard: the run "
              "deteriorates against SimpleAgent_NoBomb.", ("static", "simple_nobomb"),
              ("no_shaping", "paper")),
)

# Our recipes beyond the paper -> the paper's agent each sets out to beat (issue 14, item 6):
# measured against the same rows, its table sits beside that agent's figures.
BEYOND_THE_PAPER = {"ppo_team": "ppo", "ppo_dual_clip": "ppo", "ppo_league": "ppo"}


def paper_table(team: str) -> tuple[str, dict[str, dict[str, Cell]]] | None:
    """The paper's table our team `team` is measured against: by name, a version or a variant
    of a policy (`imitation_v1`, `ppo_league_v1`) by the name without that suffix, a recipe of
    ours (or a version of one) by the paper agent it sets out to beat."""
    base = re.sub(r"_v\d+$", "", team)
    for name in (team, base, BEYOND_THE_PAPER.get(team, ""), BEYOND_THE_PAPER.get(base, "")):
        if name in PAPER_TABLES:
            return PAPER_TABLES[name]
    return None
