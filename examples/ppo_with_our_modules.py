"""Example of training our PPO module on the Team env from a PPOConfig of your own.

Team {0, 2} runs `PommerPPOModule` (one module shared by both seats): the paper's policy CNN,
starting from the shipped imitation weights (`policies/imitation`), beside a separate value CNN.
SimpleAgent plays seats 1 and 3 as a fixed module (never trained) that runs the compiled rule on
the exact observation arrays, which it rebuilds from the "raw" half of the env's Dict observation.
Everything else is plain RLlib: the registered env "pommerman_team", a `MultiRLModuleSpec`, a
policy mapping function and `algo.train()`. `python -m rllib_pommer.train` builds the same pieces
(plus the curriculum, the filters and a fused-Adam learner) from a curriculum file.


How to run this script
----------------------
`python examples/ppo_with_our_modules.py --iters 5`

`--smoke` runs one small iteration (60-step games, 400 env steps) for a quick check.
`--opponent NAME` puts another policy in seats 1 and 3 (`static`, `simple_nobomb`, a policy file,
...). Starts its own Ray instance with `--num-cpus` CPUs (default 2).


Results to expect
-----------------
One line per iteration: episodes, the learner team's mean episode return per seat (shaped reward:
+1 win, +0.5 one enemy dead, -1 otherwise), env steps/s. The imitation start against SimpleAgent
returned -0.455 in its first iteration (11 games); PPO moves it slowly (the paper's clip is 0.01,
and the project's curricula run for hours). `python -m rllib_pommer.train` is also faster per env
step (more envs per runner, episodes kept as lists, fused Adam: rllib_pommer/rl/config.py).
"""

import argparse
import time

import ray
from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
from ray.rllib.core.rl_module.rl_module import RLModuleSpec

import rllib_pommer.rl.env  # noqa: F401  (registers the env)
from rllib_pommer.agents.registry import resolve_policy
from rllib_pommer.curriculum.names import ENV_NAME
from rllib_pommer.game.constants import MAX_STEPS
from rllib_pommer.rl.fixed_modules import fixed_module_spec
from rllib_pommer.rl.rl_module import PommerPPOModule

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--iters", type=int, default=5, help="training iterations")
parser.add_argument("--opponent", default="simple", help="policy name for seats 1 and 3")
parser.add_argument("--num-cpus", type=int, default=2)
parser.add_argument("--smoke", action="store_true", help="one small iteration, short games")


def imitation_weights() -> str:
    """The weights file the shipped `imitation` policy file names (relative to that file)."""
    spec = resolve_policy("imitation")
    return str(spec.path.parent / spec.params["weights"])


def team_mapping(agent_id, episode, **kwargs):
    return "learner" if agent_id % 2 == 0 else "opponent"


if __name__ == "__main__":
    args = parser.parse_args()
    iters, max_steps, batch = (1, 60, 400) if args.smoke else (args.iters, MAX_STEPS, 4000)

    config = (
        PPOConfig()
        .environment(ENV_NAME, env_config={"max_steps": max_steps})
        .env_runners(num_env_runners=0, num_envs_per_env_runner=2)
        .multi_agent(
            policies={"learner", "opponent"},
            policy_mapping_fn=team_mapping,
            policies_to_train=["learner"],
        )
        .rl_module(
            rl_module_spec=MultiRLModuleSpec(
                rl_module_specs={
                    "learner": RLModuleSpec(
                        module_class=PommerPPOModule,
                        model_config={"pi_weights": imitation_weights()},
                    ),
                    "opponent": fixed_module_spec(args.opponent),
                }
            )
        )
        # The paper's PPO: clip 0.01, no entropy bonus, minibatches of 128.
        .training(
            lr=1e-4, gamma=0.999, clip_param=0.01, entropy_coeff=0.0, minibatch_size=128,
            num_epochs=1 if args.smoke else 4, train_batch_size_per_learner=batch,
        )
    )

    # A Ray instance of our own (address="local"), even where another one runs on this machine.
    ray.init(address="local", num_cpus=args.num_cpus, include_dashboard=False)
    algo = config.build_algo()
    try:
        for i in range(1, iters + 1):
            start = time.perf_counter()
            runners = algo.train()["env_runners"]
            steps = runners["num_env_steps_sampled"]
            returns = runners["agent_episode_returns_mean"]  # by agent id, as a string
            print(f"iter {i}: episodes {runners['num_episodes']}, learner team's mean return "
                  f"{(returns['0'] + returns['2']) / 2:+.3f}, "
                  f"{steps / (time.perf_counter() - start):.0f} env steps/s")
    finally:
        algo.stop()
        ray.shutdown()
