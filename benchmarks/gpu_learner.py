"""The learner on a GPU beside the learner on a CPU, for a machine with a CUDA GPU:

    python benchmarks/gpu_learner.py [--curriculum league] [--iterations 3] [--updates 3]
                                     [--out gpu_learner.json]
    python benchmarks/gpu_learner.py --dry-run     # anywhere: the same steps on CPUs, test-sized

1. A few iterations of the curriculum (default `league`: its value warm-up, so pi is frozen) with
   the learner on the GPU, as `train --num-gpus-per-learner 1` runs it (the learner in the
   algorithm's process, sampling on the CPU): the whole loop's env steps/s. Then a checkpoint.
2. The checkpoint restored into a CPU run, as `train --resume --num-gpus-per-learner 0` builds it:
   every module's weights and the optimizer's moments must be equal to the GPU learner's.
3. Learner samples/s: the same sampled batches (`--updates` of them, after one to warm up)
   updated with pi trainable by the GPU learner and by the CPU learner restored in 2 (one torch
   thread, a training run's default), each from the checkpoint's weights.

It prints a table and writes the figures with the device's name, torch's and CUDA's versions as
JSON (`--out`). `--dry-run` runs the GPU learner on the CPU with test-sized batches and one
iteration and update, so that the script is checked where there is no GPU; its figures measure
nothing. Not part of CI.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import sys
import time
from pathlib import Path

DRY_PPO = {"train_batch_size": 320, "num_envs_per_env_runner": 4, "num_epochs": 1}


def _states(algo) -> dict:
    """The learner's module and optimizer states, as numpy (RLlib's checkpoint format)."""
    state = algo.learner_group.get_state(components=["learner/rl_module", "learner/optimizer"])
    return state["learner"]


def _flat(state, prefix=()):
    if isinstance(state, dict):
        for key, value in state.items():
            yield from _flat(value, (*prefix, str(key)))
    else:
        yield prefix, state


def _equal(a: dict, b: dict) -> tuple[bool, int]:
    """Whether every array of `a` is in `b` and equal, and how many arrays were compared."""
    import numpy as np

    a, b = dict(_flat(a)), dict(_flat(b))
    arrays = [k for k, v in a.items() if isinstance(v, np.ndarray)]
    same = all(k in b and np.array_equal(a[k], b[k]) for k in arrays)
    return same and bool(arrays), len(arrays)


def _learner_rows(episodes) -> int:
    from rllib_pommer.curriculum.names import LEARNER

    return sum(len(e) for episode in episodes for e in episode.agent_episodes.values()
               if e.module_id == LEARNER)


def _samples_per_s(algo, batches, sync) -> float:
    """Learner rows updated per second over `batches` (the first a warm-up), pi trainable."""
    from rllib_pommer.curriculum.names import LEARNER

    config = algo.config
    algo.learner_group.foreach_learner(lambda learner: learner.module[LEARNER].set_pi_frozen(False))
    rows = seconds = 0.0
    for index, episodes in enumerate(batches):
        episodes = copy.deepcopy(episodes)  # the learner connector extends them
        start = time.perf_counter()
        algo.learner_group.update(episodes=episodes, num_epochs=config.num_epochs,
                                  minibatch_size=config.minibatch_size,
                                  shuffle_batch_per_epoch=True)
        sync()
        if index:
            seconds += time.perf_counter() - start
            rows += _learner_rows(episodes) * config.num_epochs
    return rows / seconds


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--curriculum", default="league")
    parser.add_argument("--iterations", type=int, default=3)
    parser.add_argument("--updates", type=int, default=3, help="timed updates per learner")
    parser.add_argument("--num-cpus", type=int, default=2, help="of the Ray instance started here")
    parser.add_argument("--out", type=Path, default=Path("gpu_learner.json"))
    parser.add_argument("--dry-run", action="store_true",
                        help="the GPU learner on the CPU, test-sized: checks the script")
    args = parser.parse_args(argv)
    if args.iterations < 1 or args.updates < 1:
        parser.error("--iterations and --updates must be 1 or more")

    import ray
    import torch
    from ray.rllib.execution.rollout_ops import synchronous_parallel_sample

    from rllib_pommer.curriculum.curriculum import load_curriculum
    from rllib_pommer.rl.config import build_config

    if not args.dry_run and not torch.cuda.is_available():
        parser.error("no CUDA GPU here; --dry-run runs the same steps on CPUs")
    curriculum = load_curriculum(args.curriculum)
    iterations, updates = args.iterations, args.updates
    if args.dry_run:
        curriculum = dataclasses.replace(curriculum, ppo=dataclasses.replace(curriculum.ppo,
                                                                             **DRY_PPO))
        iterations, updates = 1, 1
    gpus = 0 if args.dry_run else 1
    device = torch.cuda.get_device_name(0) if gpus else "cpu (dry run)"

    def sync():
        if gpus:
            torch.cuda.synchronize()

    torch.set_num_threads(1)  # a training run's driver and learner (train --torch-threads 1)
    torch.set_flush_denormal(True)
    ray.init(address="local", num_cpus=args.num_cpus, include_dashboard=False)
    folder = args.out.resolve().with_suffix("")  # the checkpoint, beside the JSON
    try:
        gpu = build_config(curriculum, num_gpus_per_learner=gpus).build_algo()
        learner = gpu.learner_group._learner
        on_device = {str(p.device) for module in learner.module.values()
                     if isinstance(module, torch.nn.Module) for p in module.parameters()}
        steps = seconds = 0.0
        for iteration in range(iterations):
            start = time.perf_counter()
            result = gpu.train()
            if iteration or iterations == 1:  # the first iteration warms up
                seconds += time.perf_counter() - start
                steps += result["env_runners"]["num_env_steps_sampled"]
        checkpoint = gpu.save_to_path(str(folder / "checkpoint"))
        saved = _states(gpu)
        batches = [synchronous_parallel_sample(
            worker_set=gpu.env_runner_group, max_env_steps=gpu.config.total_train_batch_size,
            _uses_new_env_runners=True) for _ in range(updates + 1)]

        cpu = build_config(curriculum, restore_from=Path(checkpoint)).build_algo()
        equal, arrays = _equal(saved, _states(cpu))
        cpu_rate = _samples_per_s(cpu, batches, lambda: None)
        cpu.stop()
        gpu_rate = _samples_per_s(gpu, batches, sync)
        gpu.stop()
    finally:
        ray.shutdown()
    figures = {
        "device": device, "dry_run": args.dry_run, "torch": torch.__version__,
        "cuda": torch.version.cuda, "curriculum": curriculum.name,
        "learner_devices": sorted(on_device), "iterations": iterations, "updates": updates,
        "loop_env_steps_per_s": steps / seconds,
        "gpu_learner_samples_per_s": gpu_rate, "cpu_learner_samples_per_s": cpu_rate,
        "gpu_speedup": gpu_rate / cpu_rate,
        "weights_equal_on_cpu": equal, "arrays_compared": arrays, "checkpoint": checkpoint,
    }
    print(f"{'learner':<8} {'device':<32} {'loop env steps/s':>17} {'learner samples/s':>18}")
    print(f"{'gpu':<8} {device[:32]:<32} {figures['loop_env_steps_per_s']:>17.0f} "
          f"{gpu_rate:>18.0f}")
    print(f"{'cpu':<8} {'cpu, 1 torch thread':<32} {'-':>17} {cpu_rate:>18.0f}")
    print(f"GPU learner {figures['gpu_speedup']:.2f}x the CPU learner's samples/s; checkpoint "
          f"moved to a CPU run: {arrays} arrays, "
          f"{'all equal' if equal else 'NOT EQUAL'}" + (" (dry run: no GPU)" if args.dry_run
                                                        else ""))
    args.out.write_text(json.dumps(figures, indent=2) + "\n")
    print(f"wrote {args.out}")
    return 0 if equal else 1


if __name__ == "__main__":
    sys.exit(main())
