"""One training run of a curriculum through Tune: checkpoints, TensorBoard logs, progress, resume.

The run directory holds one Tune trial per start of the run, its legs: `<run>/<trial>/
checkpoint_*` (ordinary RLlib checkpoints, the latest three), the trial's `result.json`,
`progress.csv` and TensorBoard event files; `<run>/stages/<n>-<name>/`, the checkpoint at the
end of each finished stage; and `curriculum.json`, the curriculum it trains on. The run stops
once the lifetime episode count reaches the curriculum's total.

A run is resumed from its data, never from pickled code: `resume` packs the run
(`packing.pack_run`: the newest whole checkpoint on disk is kept, also after a SIGKILL), then
starts a new Tune trial whose algorithm, built from the curriculum and the command's settings
as a new run's is, loads that checkpoint's state when it is built (rl/stages.py). Since the stage
follows from the restored lifetime episode count, stage, counters, league and iteration pick up
where they were; the run's history reads its legs as one (runs/history.py). Nothing Tune pickled
(its experiment state, `params.pkl`) is read again, so a run resumes after our modules moved,
and with another layout: env runners, learner actors and GPUs (a checkpoint holds the first
learner's state whatever the number of learners). Tune saves its state and copies the trial's
result files to the run folder every 10 s (`SNAPSHOT_PERIOD_S`); what saving on every controller
step costs is in docs/measurements.md.

A run outlives the machine it ran on: `packing.py` stops it at a checkpoint and packs its folder
for `--resume` anywhere.
"""

from __future__ import annotations

import os
import socket
from pathlib import Path

import ray
import torch
from ray import tune

from ..curriculum.curriculum import (
    DEFAULT_CURRICULUM,
    Curriculum,
    load_curriculum,
    record_run_curriculum,
    resume_curriculum,
)
from ..curriculum.names import LEARNER_THREADS_ENV
from ..curriculum.settings import RunSettings
from ..rl.config import build_config, check_weights
from ..util.errors import first_sentence
from . import quiet, ray_session
from .packing import has_run, pack_run, take_stop_request
from .tune_callbacks import Progress, StageCheckpoints, StopOnRequest

STOP_KEY = "env_runners/num_episodes_lifetime"
# TUNE_GLOBAL_CHECKPOINT_S. A SIGKILL loses at most these seconds of result rows, never a
# checkpoint: the trainer writes those itself, and `--resume` packs first.
SNAPSHOT_PERIOD_S = "10"


class RayStartError(RuntimeError):
    """Ray did not come up. Its traceback (GCS time-outs, raylet logs) tells a user little; the
    message names the failure in one line and what to check."""


RAY_START_HINT = ("check free memory and disk (Ray writes to /tmp/ray and /dev/shm), whether "
                  "Ray processes of an earlier run linger (`ray status`), and the logs in "
                  "/tmp/ray/session_latest/logs")


def init_ray(address: str | None, *, num_cpus: int = RunSettings.num_cpus,
             torch_threads: int = RunSettings.torch_threads) -> None:
    """A Ray instance of our own on this machine (`num_cpus` CPUs), or an existing cluster at
    `address`. Our own, even where `ray start` left a cluster running here: a plain `ray.init()`
    would join that one (and refuse `num_cpus`). A bad address is a ValueError; a Ray that does
    not start, a `RayStartError`."""
    torch.set_num_threads(torch_threads)
    torch.set_flush_denormal(True)
    quiet.silence()  # here, and in every worker through the hook below
    job_env = {"env_vars": {LEARNER_THREADS_ENV: str(torch_threads)},  # for learner.py
               "worker_process_setup_hook": "rllib_pommer.launch.quiet.silence"}
    if address is not None and address != "auto":
        host, _, port = address.removeprefix("ray://").rpartition(":")
        try:
            socket.create_connection((host or "127.0.0.1", int(port)), timeout=5).close()
        except (OSError, ValueError) as exc:
            raise ValueError(f"Ray address {address!r} is unreachable ({exc}); expected "
                             f"HOST:PORT of a running cluster's head, or 'auto'") from None
    try:
        if address is None:
            ray.init(address="local", num_cpus=num_cpus, include_dashboard=False,
                     runtime_env=job_env)
        else:
            ray.init(address=address, runtime_env=job_env)
    except Exception as exc:  # Ray raises many types here; each becomes one line
        if address is not None and "AuthToken" in f"{exc} {exc.__cause__}":
            raise ValueError(
                f"the Ray cluster at {address!r} wants a token (`ray start` turns token "
                f"authentication on): run with RAY_AUTH_MODE=token and the cluster's token in "
                f"~/.ray/auth_token, RAY_AUTH_TOKEN or RAY_AUTH_TOKEN_PATH") from None
        where = f"the Ray cluster at {address!r}" if address else "a local Ray instance"
        raise RayStartError(f"{where} did not start ({first_sentence(exc)}); "
                            f"{RAY_START_HINT}") from None


def check_run_dir(out: Path, resume: bool) -> None:
    """Refuse, before any work, an --out that cannot be used: a new run over an existing one,
    or a resume without a run."""
    out = Path(out).resolve()
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file, not a run directory")
    if resume and not has_run(out):
        raise ValueError(f"--resume: no run to resume in {out}")
    if not resume and has_run(out):
        raise ValueError(f"{out} already holds a run; pass --resume or another --out")


def start_run(settings: RunSettings, say=print) -> tuple[Curriculum, Path, Path | None]:
    """Everything a run checks before Ray starts, then Ray: the curriculum and the run directory
    (default runs/<curriculum name>), after ending what a SIGKILLed run in that directory left
    running (told to `say`), dropping a stop request no run took, and, to resume, packing it
    (module docstring). Bad input is a
    ValueError; a Ray that does not start, a `RayStartError`."""
    given = load_curriculum(settings.curriculum) if settings.curriculum else None
    out = settings.out or Path("runs") / (given.name if given else DEFAULT_CURRICULUM)
    ended = ray_session.reap(out)
    if ended:
        say(f"ended {len(ended)} Ray processes left by the killed run in {out}")
    take_stop_request(out)  # one left by a `--stop` that did not see the run end: not this run's
    check_run_dir(out, settings.resume)
    curriculum = (resume_curriculum(out, given) if settings.resume
                  else given or load_curriculum(DEFAULT_CURRICULUM))
    start = None
    if settings.resume:
        start = pack_run(out)
        say(f"{out}: resuming from {start.parent.name}/{start.name}" if start else
            f"{out}: no checkpoint to resume from; the run starts over")
    if start is None:  # else pi and vf come from the checkpoint
        check_weights(settings.pi_weights or curriculum.pi_weights)
        if curriculum.vf_weights:
            check_weights(curriculum.vf_weights, part="vf")
    init_ray(settings.address, num_cpus=settings.num_cpus, torch_threads=settings.torch_threads)
    if settings.address is None:  # our own Ray: note it, for the next start to clean up after
        ray_session.record(out)
    try:
        if settings.address is not None:
            check_cluster_fits(settings)
        check_gpus(settings)
        if settings.address is not None:
            check_learner_fits_a_node(settings)
    except ValueError:
        ray.shutdown()  # leave the cluster (or end our own Ray) before the error ends the command
        raise
    if settings.address is not None:  # a cluster: note the driver alone, for `train --stop`
        ray_session.record(out, cluster=True)
    record_run_curriculum(out, curriculum,
                          pi_start=None if start else settings.pi_weights or curriculum.pi_weights)
    say(f"TensorBoard: tensorboard --logdir {out} (Tune's own hint below names a folder of the "
        f"Ray session under /tmp/ray, not the run's)")
    return curriculum, out, start


def check_cluster_fits(settings: RunSettings) -> None:
    """Refuse a run the cluster's free CPUs cannot hold: Tune would wait for them for ever,
    printing "insufficient resources" every minute. The run asks for the algorithm's process
    (one CPU, or its learner's `--num-cpus-per-learner` where it holds the learner), each
    learner actor's `--num-cpus-per-learner`, and `cpus_per_env_runner` for each remote
    runner, counted over all the nodes (`check_learner_fits_a_node` checks that a learner fits
    one)."""
    free = ray.available_resources().get("CPU", 0.0)
    runners = settings.num_env_runners * cpus_per_env_runner(settings)
    fixed = settings.main_process_cpus + settings.learner_cpus
    if fixed + runners > free + 1e-9:
        fits = max(int(free - fixed + 1e-9), 0)
        learners = (f"{settings.main_process_cpus:g} for the learner's process"
                    if not settings.num_learners else
                    f"1 for the algorithm's process, {settings.learner_cpus:g} for "
                    f"--num-learners {settings.num_learners}")
        raise ValueError(
            f"the Ray cluster at {settings.address!r} has {free:g} free CPUs; the run asks for "
            f"{fixed + runners:g} ({learners}, {runners:g} for "
            f"--num-env-runners {settings.num_env_runners}): "
            + (f"pass --num-env-runners {fits} or fewer, or " if free >= fixed else "")
            + "free or add CPUs")


def check_learner_fits_a_node(settings: RunSettings) -> None:
    """Refuse a learner that no single node of the cluster can hold. Its CPUs and GPUs are one
    bundle, which Ray places on one node, so a learner asking for more than any node has would
    wait for ever as well, however many the nodes have together. (One CPU and no GPU, what an
    env runner asks for, fits any node with a CPU.)"""
    gpus = settings.num_gpus_per_learner
    cpus = settings.num_cpus_per_learner if settings.num_learners else settings.main_process_cpus
    if cpus <= 1 and not gpus:
        return
    nodes = [node["Resources"] for node in ray.nodes() if node["Alive"]]
    if any(node.get("CPU", 0.0) + 1e-9 >= cpus and node.get("GPU", 0.0) + 1e-9 >= gpus
           for node in nodes):
        return
    most_cpus = max((node.get("CPU", 0.0) for node in nodes), default=0.0)
    most_gpus = max((node.get("GPU", 0.0) for node in nodes), default=0.0)
    who = (f"each of --num-learners {settings.num_learners}" if settings.num_learners
           else "the learner in the algorithm's process")
    flags = f"--num-cpus-per-learner {settings.num_cpus_per_learner:g}" + (
        f", --num-gpus-per-learner {gpus:g}" if gpus else "")
    raise ValueError(
        f"the Ray cluster at {settings.address!r} has no node with {cpus:g} CPUs"
        + (f" and {gpus:g} GPUs" if gpus else "") + f" for {who} ({flags}), which Ray places "
        f"on one node; its nodes have at most {most_cpus:g} CPUs"
        + (f" and {most_gpus:g} GPUs" if gpus else "") + ": ask for that or less, or add a "
        "bigger node")


def check_gpus(settings: RunSettings) -> None:
    """Refuse a run asking for more GPUs than Ray has free (on our own instance, the GPUs Ray
    found on this machine): Tune would wait for them for ever."""
    if not settings.gpus:
        return
    free = ray.available_resources().get("GPU", 0.0)
    if settings.gpus > free + 1e-9:
        where = (f"the Ray cluster at {settings.address!r}" if settings.address else
                 "this machine's Ray (it counts the GPUs CUDA_VISIBLE_DEVICES shows)")
        who = (f"--num-learners {settings.num_learners} x " if settings.num_learners
               else "the learner in the algorithm's process: ")
        raise ValueError(f"the run asks for {settings.gpus:g} GPUs ({who}--num-gpus-per-learner "
                         f"{settings.num_gpus_per_learner:g}) and {where} has {free:g} free: "
                         f"pass --num-gpus-per-learner 0 to learn on CPUs, or add GPUs")


def cpus_per_env_runner(settings: RunSettings) -> float:
    """Ray CPUs each remote env runner asks for. On a Ray instance of our own, the algorithm's
    process and the learner actors take theirs and the runners share the rest: PPO is
    synchronous, so the runners sample while the learner waits and the learner trains, on
    `--torch-threads` threads, while they wait; `--num-env-runners 2 --torch-threads 2` keeps
    both cores of a 2-core machine busy in both phases. (Ray refuses a runner of 0 CPUs;
    RunSettings refuses a layout that leaves none.) On a cluster, one each."""
    if settings.address is not None or settings.num_env_runners == 0:
        return 1.0
    left = settings.num_cpus - settings.main_process_cpus - settings.learner_cpus
    return min(1.0, left / settings.num_env_runners)  # > 0: RunSettings checks it


def train(curriculum: Curriculum, out: Path, settings: RunSettings,
          start: Path | None = None):
    """Run `curriculum` into the run directory `out` as a new Tune trial, from the checkpoint
    `start` where a resumed run goes on (`start_run` finds it); Ray must be initialised."""
    out = Path(out).resolve()
    os.environ.setdefault("TUNE_GLOBAL_CHECKPOINT_S", SNAPSHOT_PERIOD_S)
    config = build_config(curriculum, pi_weights=settings.pi_weights,
                          num_env_runners=settings.num_env_runners,
                          cpus_per_env_runner=cpus_per_env_runner(settings), seed=settings.seed,
                          restore_from=start, num_learners=settings.num_learners,
                          num_gpus_per_learner=settings.num_gpus_per_learner,
                          num_cpus_per_learner=settings.num_cpus_per_learner)
    tuner = tune.Tuner(
        config.algo_class,
        param_space=config,
        run_config=tune.RunConfig(
            name=out.name,
            storage_path=str(out.parent),
            stop={STOP_KEY: curriculum.total_episodes},
            checkpoint_config=tune.CheckpointConfig(
                checkpoint_frequency=curriculum.ppo.checkpoint_every,
                checkpoint_at_end=True, num_to_keep=3),
            callbacks=[Progress(), StageCheckpoints(), StopOnRequest()],
            verbose=0,
        ),
    )
    results = tuner.fit()
    result = results[0]
    if result.error:
        raise RuntimeError(f"training failed: {result.error}")
    return result
