"""Example of the single-agent Gymnasium env in a plain loop: a tiny REINFORCE in numpy.

`rllib_pommer/PommeTeam-v0` seats the agent being trained in seat 0 and named policies in the
other three (SimpleAgent unless `--teammate`/`--opponents` say otherwise). This script trains a
linear softmax policy over the 19 observation planes with REINFORCE: every step of an episode
takes the episode's final reward as its return (the reward is zero before; no discount), minus the
batch's mean as a baseline. With `--gif` the last episode is drawn with `render_mode="rgb_array"`.
No Ray, no torch.


How to run this script
----------------------
`python examples/gym_reinforce.py --episodes 400 --batch 50 --gif last.gif`

`--smoke` plays 4 short episodes (60 steps at most) for a quick check.


Results to expect
-----------------
One line per batch: mean return (shaped: +1 win, +0.5 one enemy dead, -1 otherwise), wins and the
mean episode length. The point is the loop, not the score: a linear policy from scratch mostly
blows itself up, and a reward paid only at the agent's last step teaches slowly. Against
SimpleAgent, 400 episodes (about a minute) stayed between -0.8 and -0.55 mean return per batch of
50, with 3-8 wins per batch (SimpleAgents' own mistakes); against `static` opponents every episode
returns -1 (the agent dies, or the game ties), so REINFORCE gets no gradient at all.
"""

import argparse
import time

import gymnasium as gym
import numpy as np
from PIL import Image

import rllib_pommer.envs  # noqa: F401  (registers rllib_pommer/PommeTeam-v0)
from rllib_pommer.game.constants import MAX_STEPS

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--episodes", type=int, default=100)
parser.add_argument("--batch", type=int, default=10, help="episodes per policy update")
parser.add_argument("--lr", type=float, default=0.01)
parser.add_argument("--teammate", default="simple", help="policy name in seat 2")
parser.add_argument("--opponents", default="simple", help="policy name in seats 1 and 3")
parser.add_argument("--max-steps", type=int, default=MAX_STEPS)
parser.add_argument("--seed", type=int, default=0)
parser.add_argument("--gif", help="write the last episode to this .gif")
parser.add_argument("--smoke", action="store_true", help="4 episodes of at most 60 steps")


def softmax(logits: np.ndarray) -> np.ndarray:
    z = np.exp(logits - logits.max())
    return z / z.sum()


if __name__ == "__main__":
    args = parser.parse_args()
    if args.smoke:
        args.episodes, args.batch, args.max_steps = 4, 2, 60
    if min(args.episodes, args.batch) < 1:
        parser.error("--episodes and --batch must be at least 1")
    env = gym.make("rllib_pommer/PommeTeam-v0", render_mode="rgb_array" if args.gif else None,
                   teammate=args.teammate, opponents=args.opponents, max_steps=args.max_steps)
    rng = np.random.default_rng(args.seed)
    weights = np.zeros((env.action_space.n, int(np.prod(env.observation_space.shape))))
    batch, start = [], time.perf_counter()

    for episode in range(args.episodes):
        obs, _ = env.reset(seed=args.seed + episode)
        last = episode == args.episodes - 1
        frames = [env.render()] if args.gif and last else []
        features, scores = [], []  # x_t, and d log pi(a_t | x_t) / d logits = onehot - pi
        done = False
        while not done:
            x = obs.ravel()
            probs = softmax(weights @ x)
            action = rng.choice(len(probs), p=probs)
            obs, reward, terminated, truncated, info = env.step(action)
            features.append(x)
            scores.append(np.eye(len(probs))[action] - probs)
            done = terminated or truncated
            if frames:
                frames.append(env.render())
        won = 0 in info.get("winners", [])  # the game ended with seat 0 alive, its team won
        batch.append((np.array(features), np.array(scores), reward, won))

        if len(batch) == args.batch or last:
            returns = np.array([r for _, _, r, _ in batch])
            for (x, score, *_), advantage in zip(batch, returns - returns.mean(), strict=True):
                weights += args.lr * advantage * score.T @ x / len(batch)
            steps = sum(len(x) for x, *_ in batch)
            print(f"episodes {episode + 1}: mean return {returns.mean():+.2f}, wins "
                  f"{sum(w for *_, w in batch)}/{len(batch)}, mean length {steps / len(batch):.0f}"
                  f", {steps / (time.perf_counter() - start):.0f} steps/s")
            batch, start = [], time.perf_counter()

    if args.gif:
        images = [Image.fromarray(f) for f in frames]
        images[0].save(args.gif, save_all=True, append_images=images[1:], duration=125, loop=0)
        print(f"wrote {args.gif}: {len(images)} frames")
    env.close()
