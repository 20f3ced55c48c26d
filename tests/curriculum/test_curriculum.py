"""The shipped curricula load, and the stage in force follows the lifetime episode count."""

from __future__ import annotations

import pytest

from rllib_pommer.curriculum.curriculum import curriculum_names, load_curriculum
from rllib_pommer.game.constants import TEAM_PRESET

from ..conftest import REPO_ROOT


@pytest.mark.parametrize("name", curriculum_names())
def test_every_shipped_curriculum_loads(name):
    curriculum = load_curriculum(name)
    assert curriculum.stages and curriculum.pi_weights.is_file()


def test_paper_schedule_is_the_papers():
    paper = load_curriculum("paper")
    assert [(s.opponent, s.episodes, s.freeze_pi) for s in paper.stages] == [
        ("simple", 10_000, True), ("static", 10_000, False),
        ("simple_nobomb", 20_000, False), ("simple", 60_000, False)]
    assert {(s.teammate, s.reward, s.action_filter, s.jitter) for s in paper.stages} == {
        ("suicide", "shaped", 0.3, 0.1)}
    assert paper.total_episodes == 100_000


def test_stage_boundaries():
    paper = load_curriculum("paper")
    assert [paper.stage_end(i) for i in range(4)] == [10_000, 20_000, 40_000, 100_000]
    assert [paper.stage_at(n) for n in (0, 9_999, 10_000, 39_999, 40_000, 99_999)] == \
        [0, 0, 1, 2, 3, 3]
    assert paper.stage_at(250_000) == 3  # an overshooting run keeps the last stage


def test_variants_share_the_value_warmup():
    for name in ("no_shaping", "no_curriculum", "cautious"):
        first = load_curriculum(name).stages[0]
        assert (first.opponent, first.episodes, first.freeze_pi) == ("simple", 10_000, True)
        assert load_curriculum(name).total_episodes == 100_000


def test_the_ablations_start_where_the_paper_run_did():
    paper = load_curriculum("paper").pi_weights
    assert paper == (REPO_ROOT / "policies/imitation_v2/pi.pt").resolve()
    assert {load_curriculum(name).pi_weights for name in ("no_shaping", "no_curriculum")} == {paper}


def test_a_file_anywhere_starts_from_the_shipped_weights_unless_it_names_its_own(tmp_path):
    stage = '[[stage]]\nname = "a"\nopponent = "static"\nepisodes = 5\n'
    (tmp_path / "mine.toml").write_text(stage)
    assert load_curriculum(tmp_path / "mine.toml").pi_weights == \
        load_curriculum("quick").pi_weights == (REPO_ROOT / "policies/imitation/pi.pt").resolve()
    (tmp_path / "own.toml").write_text('pi_weights = "w/pi.pt"\n' + stage)
    assert load_curriculum(tmp_path / "own.toml").pi_weights == (tmp_path / "w/pi.pt").resolve()


def test_episodes_last_as_long_as_the_team_game_unless_the_file_says_otherwise():
    assert load_curriculum("paper").max_steps == TEAM_PRESET.max_steps == 800
    assert load_curriculum("quick").max_steps == 400


class _Group:
    """Stands in for the env runner and learner groups: the stage push has nowhere to go."""
    def foreach_env_runner(self, func, local_env_runner=True):
        return []

    def foreach_learner(self, func):
        return []


def test_an_iteration_in_which_no_episode_ended_keeps_the_stage():
    """The first iteration after a restore may end no episode; RLlib then reports the
    iteration's episode count as NaN, and the callback counts it as none."""
    from types import SimpleNamespace

    from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS, NUM_EPISODES, NUM_EPISODES_LIFETIME

    from rllib_pommer.rl.stages import StageCallback

    algorithm = SimpleNamespace(env_runner_group=_Group(), learner_group=_Group())
    result = {ENV_RUNNER_RESULTS: {NUM_EPISODES_LIFETIME: 10_500, NUM_EPISODES: float("nan")}}
    StageCallback("paper").on_train_result(algorithm=algorithm, result=result)
    assert result["curriculum"]["stage"] == 1 and result["curriculum"]["episodes"] == 10_500
    assert result["curriculum"]["ended_stage"] is None
