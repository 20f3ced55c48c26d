"""TeamRadio through RLlib: the radio smoke curriculum trains in-process (the learner speaks and
hears, starting from Team weights with the Team move logits exactly), the filters act on the
move alone, words reach the teammate, and the checkpoint plays (and speaks) in the arena; the
curriculum key `game` is checked."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from ray.rllib.core.columns import Columns

from rllib_pommer.arena.match import MatchSpec, play_match, record_games
from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.names import LEARNER
from rllib_pommer.envs.team import RADIO_ACTION_SPACE
from rllib_pommer.imitation.features import message_features
from rllib_pommer.imitation.learned import load_policy_net
from rllib_pommer.imitation.network import RadioNet
from rllib_pommer.rl.config import build_config
from rllib_pommer.rl.env import PommeEnv
from rllib_pommer.rl.fixed_modules import fixed_module_spec
from rllib_pommer.runs.checkpoints import load_checkpoint_net

from .conftest import learner_episodes, log_softmax, smoke_run


@pytest.fixture(scope="module")
def radio_smoke(ray_session, pi_weights, tmp_path_factory):
    yield smoke_run("radio_smoke", pi_weights, tmp_path_factory.mktemp("radio_ckpt"))


def test_the_learner_starts_as_the_team_net_and_speaks_uniformly(radio_smoke, pi_weights):
    start = radio_smoke["start"]
    assert start["radio"] and start["space"] == RADIO_ACTION_SPACE
    net = RadioNet()
    net.load_state_dict(start["pi"])
    team = load_policy_net(pi_weights)
    planes = (torch.rand(16, 19, 11, 11, generator=torch.Generator().manual_seed(1)) < 0.2)
    heard = torch.from_numpy(message_features(np.random.default_rng(1).integers(0, 8, (16, 2))))
    with torch.no_grad():
        out = net.eval()(planes.float(), heard)
        assert torch.equal(out[:, :6], team(planes.float()))
    assert torch.equal(out[:, 6:], torch.zeros(16, 16))


def test_radio_stages_freeze_then_train_every_part(radio_smoke):
    iterations = radio_smoke["iterations"]
    assert [it["stage"] for it in iterations][::len(iterations) - 1] == [0, 1]
    for it in iterations:
        assert it["vf_changed"]
        assert it["pi_changed"] == (it["stage"] == 1), "pi must move only after the warm-up"
        assert it["result"]["learners"][LEARNER]["nonfinite_updates_skipped"] == 0
    trained, start = radio_smoke["trained"], radio_smoke["start"]["pi"]
    # the value net learned to hear; pi learned to hear and to speak after the warm-up
    assert trained["vf"]["hear.weight"].abs().sum() > 0
    for key in ("hear.weight", "speak.weight", "speak.bias"):
        assert not torch.equal(trained["pi"][key], start[key]), key
    shares = [it["result"]["env_runners"].get("learner_override_share", 0) for it in iterations]
    assert max(shares) > 0, "the filters never overrode a move"


def test_the_stored_action_is_the_executed_one_with_its_logp(radio_smoke):
    checked = 0
    for agent_episode in learner_episodes(radio_smoke["episodes"]):
        actions = np.asarray(agent_episode.get_actions())
        assert actions.shape[1:] == (3,)
        executed = [info["executed"] for info in agent_episode.get_infos()[1:]]
        assert actions.tolist() == executed
        logits = np.asarray(agent_episode.get_extra_model_outputs("action_dist_inputs"))
        rows = np.arange(len(actions))
        expected = sum(log_softmax(part)[rows, actions[:, i]]
                       for i, part in enumerate(np.split(logits, [6, 14], axis=-1)))
        logp = np.asarray(agent_episode.get_extra_model_outputs("action_logp"))
        np.testing.assert_allclose(logp, expected, atol=1e-4)
        checked += len(actions)
    assert checked > 50


def test_the_learners_words_reach_its_teammate(radio_smoke):
    checked = 0
    for episode in radio_smoke["episodes"]:
        seats = {a: e for a, e in episode.agent_episodes.items() if e.module_id == LEARNER}
        for seat, own in seats.items():
            mate = seats.get((seat + 2) % 4)  # the learner is its own teammate
            if mate is None:  # a chunk after its death
                continue
            heard = np.asarray([obs["message"] for obs in own.get_observations()])
            sent = np.asarray(mate.get_actions())
            steps = min(len(own), len(mate))
            if steps == 0:
                continue
            np.testing.assert_array_equal(heard[1:steps + 1],
                                          message_features(sent[:steps, 1:]))
            checked += steps
    assert checked > 50
    words = np.concatenate([np.asarray(e.get_actions())[:, 1:]
                            for e in learner_episodes(radio_smoke["episodes"])])
    assert len(np.unique(words)) == 8  # sampled words, not silence


def test_the_radio_checkpoint_restores_and_plays_in_the_arena(radio_smoke):
    algo = radio_smoke["config"].build_algo()
    try:
        algo.restore(radio_smoke["checkpoint"])
        assert algo.learner_group._learner.module[LEARNER].radio
    finally:
        algo.stop()
    net = load_checkpoint_net(radio_smoke["checkpoint"])
    assert isinstance(net, RadioNet)
    for key, value in net.state_dict().items():
        assert torch.equal(value, radio_smoke["trained"]["pi"][key])
    assert isinstance(load_checkpoint_net(radio_smoke["checkpoint"], "vf"), RadioNet)
    records = list(play_match(MatchSpec(team=radio_smoke["checkpoint"], vs="static", games=4,
                                        variant="radio"), workers=1))
    assert len(records) == 4 and {r.variant for r in records} == {"radio"}
    # outside RLlib too the checkpoint's net speaks: its agents' recorded words are not silence
    (replay,) = record_games(MatchSpec(team=radio_smoke["checkpoint"], vs="static", games=1,
                                       variant="radio"), 1)
    said = {tuple(step["full_actions"][s][1:]) for step in replay["steps"]
            for s in replay["seats_a"] if isinstance(step["full_actions"][s], list)}
    assert len(said) > 3


@pytest.mark.parametrize(("text", "message"), [
    ('game = "ffa"\n', r"game 'ffa' is not one of \['team', 'radio'\]"),
    ('game = 3\n', "game must be a string, got 3"),
    ('game = "radio"\n[league]\nslots = 2\n', r"a \[league\] .* plays the Team game only"),
    ('game = "radio"\n[defaults]\nteammate = "simple_words"\n',
     r"policy 'simple_words' speaks \(its '_words' suffix\), which the fixed RLlib modules"),
])
def test_a_bad_game_is_refused_naming_the_file(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text + '[[stage]]\nname = "a"\nopponent = "static"\nepisodes = 5\n')
    with pytest.raises(ValueError, match=f"curriculum file {path}.*{message}"):
        load_curriculum(path)


def test_team_curricula_stay_team():
    assert load_curriculum("smoke").game == "team" and load_curriculum("radio_smoke").game == \
        "radio"
    team_env = build_config(load_curriculum("smoke")).env_config
    assert "game" not in team_env  # a Team run under way resumes with its key set
    assert build_config(load_curriculum("radio_smoke")).env_config["game"] == "radio"


def _talker(tmp_path, greedy: bool) -> str:
    """A policy file of a radio network whose hearing and speaking are not zero."""
    torch.manual_seed(3)
    net = RadioNet()
    torch.nn.init.normal_(net.hear.weight)
    torch.nn.init.normal_(net.speak.weight)
    (tmp_path / "talker").mkdir(exist_ok=True)
    torch.save(net.state_dict(), tmp_path / "talker" / "pi.pt")
    policy = tmp_path / f"talker_{greedy}.toml"
    policy.write_text(f'kind = "learned"\nweights = "talker/pi.pt"\n'
                      f'greedy = {str(greedy).lower()}\n')
    return str(policy)


def _frozen(policy: str, env: PommeEnv):
    spec = fixed_module_spec(policy)
    spec.observation_space, spec.action_space = env.observation_spaces[0], env.action_spaces[0]
    return spec.build()


def _batch(env: PommeEnv) -> dict:
    obs, _ = env.reset(seed=4)
    obs, *_ = env.step({0: [0, 1, 2], 1: [0, 3, 4], 2: [0, 5, 6], 3: [0, 7, 0]})
    return {Columns.OBS: {key: torch.as_tensor(np.stack([obs[a][key] for a in range(4)]))
                          for key in ("planes", "message")}}


def test_a_frozen_radio_net_speaks_and_a_team_net_plays_moves_in_teamradio(tmp_path):
    radio_env = PommeEnv({"game": "radio"})
    batch = _batch(radio_env)
    greedy = _frozen(_talker(tmp_path, greedy=True), radio_env)
    with torch.no_grad():
        actions = greedy.forward_inference(batch)[Columns.ACTIONS]
        logits = greedy.pi(batch[Columns.OBS]["planes"], batch[Columns.OBS]["message"])
    assert actions.shape == (4, 3)
    expected = [part.argmax(-1) for part in logits.split([6, 8, 8], dim=-1)]
    assert torch.equal(actions, torch.stack(expected, -1))
    sampling = _frozen(_talker(tmp_path, greedy=False), radio_env)
    with torch.no_grad():
        out = sampling.forward_exploration(batch)
    assert out[Columns.ACTION_DIST_INPUTS].shape == (4, 22)
    dist = sampling.get_exploration_action_dist_cls().from_logits(out[Columns.ACTION_DIST_INPUTS])
    assert RADIO_ACTION_SPACE.contains(dist.sample()[0].numpy().astype(np.int64))
    team = _frozen("imitation_sampling", radio_env)  # a Team net: moves alone, words (0, 0)
    with torch.no_grad():
        moves = team.forward_exploration(batch)[Columns.ACTIONS]
    assert moves.shape == (4,) and ((moves >= 0) & (moves < 6)).all()
    with pytest.raises(ValueError, match="is a TeamRadio network; it plays only in TeamRadio"):
        _frozen(_talker(tmp_path, greedy=True), PommeEnv())
