"""The env's API (RLlib's multi-agent check), seeding, deaths and rewards; the PettingZoo env
plays the same episodes (PettingZoo's own tests: tests/envs/test_envs.py)."""

from __future__ import annotations

import numpy as np
from ray.rllib.utils.pre_checks.env import check_multiagent_environments

from rllib_pommer.envs.multi_agent import PommeParallelEnv
from rllib_pommer.rl.env import PommeEnv


def _play(env, seed, steps=10_000):
    """Random play of one episode; the per-step dicts."""
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    history = []
    for _ in range(steps):
        out = env.step({a: int(rng.integers(6)) for a in env.agents})
        history.append(out)
        if out[2]["__all__"]:
            break
    return obs, history


def test_rllib_multi_agent_check():
    check_multiagent_environments(PommeEnv({"seed": 0}))


def test_pettingzoo_env_plays_the_rllib_envs_episodes():
    """One game definition (envs.team): same seed and actions, same planes and rewards; the
    PettingZoo env still answers at its old import path."""
    rllib_env, pz_env = PommeEnv({"max_steps": 300}), PommeParallelEnv({"max_steps": 300})
    (obs, _), (pz_obs, _) = rllib_env.reset(seed=5), pz_env.reset(seed=5)
    rng, done = np.random.default_rng(5), False
    while not done:
        assert all(np.array_equal(obs[a]["planes"], pz_obs[f"player_{a}"]) for a in obs)
        actions = {a: int(rng.integers(6)) for a in rllib_env.agents}
        obs, rewards, terminateds, _, _ = rllib_env.step(actions)
        pz_obs, pz_rewards, *_ = pz_env.step({f"player_{a}": x for a, x in actions.items()})
        assert pz_rewards == {f"player_{a}": r for a, r in rewards.items()}
        done = terminateds["__all__"]
    assert pz_env.agents == []


def test_same_seed_same_episode():
    (obs_a, hist_a), (obs_b, hist_b) = (_play(PommeEnv(), seed=7) for _ in range(2))
    assert len(hist_a) == len(hist_b)
    assert np.array_equal(obs_a[1]["raw"], obs_b[1]["raw"])
    for (o_a, r_a, *_), (o_b, r_b, *_) in zip(hist_a, hist_b, strict=True):
        assert r_a == r_b
        assert all(np.array_equal(o_a[k]["raw"], o_b[k]["raw"]) for k in o_a)


def test_dead_agents_leave_with_final_reward_and_shaping():
    for seed in range(6):
        env = PommeEnv({"seed": seed, "reward": "shaped"})
        _, history = _play(env, seed)
        gone, finals = set(), {}
        for obs, rewards, terminateds, _, infos in history:
            assert not gone & set(obs), "a dead agent got another observation"
            for agent, done in terminateds.items():
                if agent != "__all__" and done:
                    gone.add(agent)
                    finals[agent] = (rewards[agent], infos[agent].get("winners"))
                elif agent != "__all__":
                    assert rewards[agent] == 0.0
        assert gone == {0, 1, 2, 3}
        for agent, (reward, winners) in finals.items():
            assert reward in (-1.0, 0.5, 1.0)
            assert (reward == 1.0) == (winners is not None and agent in winners)
