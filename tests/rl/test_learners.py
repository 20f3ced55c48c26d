"""Learners as RLlib scales them (`train --num-learners N --num-gpus-per-learner G
--num-cpus-per-learner C`): the options are checked before Ray starts, the layout fits the Ray
instance or is refused in one line, two learner actors split PPO's batch and average their
gradients (rl/learner.py) so that they keep one set of weights through the value warm-up, the
dual clip, the skip of non-finite updates and a league with its gate, matchmaking book and
exploiter (rl/league.py), and a checkpoint moves between 2 learners and 0, and another number of
env runners, with every module's weights and the league's book as they were."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import torch

from rllib_pommer.curriculum.curriculum import load_curriculum
from rllib_pommer.curriculum.names import EXPLOITER, LEARNER
from rllib_pommer.curriculum.settings import RunSettings
from rllib_pommer.launch.training import check_cluster_fits, check_gpus, cpus_per_env_runner
from rllib_pommer.rl.config import build_config
from rllib_pommer.rl.league import MATCHMAKING_MODULE, members, read_book
from rllib_pommer.rl.rl_module import vf_autocast

# A value warm-up (pi frozen; a static teammate, so the fixed seats have three times the
# learner's steps: RLlib's own count of minibatches for N learners would train each row about
# three times), then a league with self-play, prioritized matchmaking (its book kept, its floor
# making the turns even) and an exploiter, paid for kills, with a dual clip. Suicide opponents
# lose every game: a block with their turn passes the gate.
LEARNERS_SMOKE = """
name = "learners_smoke"
description = "Two learners, test-sized."
max_steps = 40
[ppo]
train_batch_size = 320
num_epochs = 1
num_envs_per_env_runner = 4
dual_clip = 1.001
[league]
slots = 2
gate_games = 4
gate_win = 0.25
matchmaking = "prioritized"
priority_floor = 1.0
exploiter = true
[defaults]
reward = "raw_kills"
action_filter = 0.0
jitter = 0.0
[[stage]]
name = "warmup"
teammate = "static"
opponent = "static"
episodes = 8
freeze_pi = true
[[stage]]
name = "league"
teammate = "learner"
opponent = ["suicide", "static_action"]
episodes = 100000
self_play = true
"""

TWO_LEARNERS = {"num_learners": 2, "num_cpus_per_learner": 0.5}
REPO = Path(__file__).resolve().parents[2]  # 1 + 2 x 0.5: the tests' Ray


@pytest.mark.parametrize("args, error", [
    (["--num-learners", "-1"], "--num-learners must be 0 or more, got -1"),
    (["--num-gpus-per-learner", "-0.5"],
     "--num-gpus-per-learner must be a number of 0 or more, got -0.5"),
    (["--num-cpus-per-learner", "nan"], "--num-cpus-per-learner must be a number of 0 or more"),
    (["--num-gpus-per-learner", "1.5"],
     "--num-gpus-per-learner must be below 1 or a whole number (Ray's rule for resources), "
     "got 1.5"),
    (["--num-learners", "1", "--num-cpus-per-learner", "0"], "a learner needs a CPU or a GPU"),
    (["--num-learners", "2"],
     "the run asks for 3 Ray CPUs (1 for the algorithm's process and 2 for --num-learners 2 x "
     "--num-cpus-per-learner 1) but --num-cpus is 2 (Tune would wait for CPUs forever): pass "
     "--num-cpus 3 or more"),
    (["--num-cpus-per-learner", "3"],
     "the run asks for 3 Ray CPUs (3 for the learner's process (--num-cpus-per-learner 3)) but "
     "--num-cpus is 2"),
    (["--num-learners", "2", "--num-cpus-per-learner", "0.5", "--num-env-runners", "1"],
     "--num-env-runners 1 needs a share of a CPU beside the 2 the run's learners take"),
])
def test_learner_options_are_checked_before_ray(tmp_path, capsys, args, error):
    from rllib_pommer.train import main

    with pytest.raises(SystemExit) as exited:
        main(["--out", str(tmp_path / "run"), *args])
    assert exited.value.code == 2 and error in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_the_learners_take_their_cpus_before_the_env_runners():
    assert RunSettings(**TWO_LEARNERS).learner_cpus == 1.0
    # 4 CPUs: 1 for the algorithm's process, 1 learner, 2 left for 2 runners
    assert cpus_per_env_runner(RunSettings(num_learners=1, num_cpus=4, num_env_runners=2)) == 1.0
    assert cpus_per_env_runner(RunSettings(num_learners=1, num_cpus=3, num_env_runners=4)) == 0.25
    assert cpus_per_env_runner(RunSettings(num_learners=2, num_cpus_per_learner=0.25,
                                           num_env_runners=1)) == 0.5
    gpu = RunSettings(num_learners=2, num_cpus_per_learner=0, num_gpus_per_learner=1)
    assert (gpu.learner_cpus, gpu.gpus) == (0, 2)
    assert RunSettings(num_gpus_per_learner=0.5).gpus == 0.5  # the learner in the driver's process
    assert RunSettings(num_learners=3, address="auto").num_learners == 3  # a cluster: checked there


@pytest.mark.parametrize("learners, cpus, gpus", [(0, 1, 0), (2, 0.5, 0), (1, 0, 1), (0, 1, 1)])
def test_tune_asks_ray_for_each_learner_where_it_runs(pi_weights, learners, cpus, gpus):
    """The placement group Tune requests: the algorithm's process (with the learner's GPU where
    it holds the learner), one bundle per learner actor; PPO's batch split over the learners."""
    curriculum = load_curriculum("smoke")
    config = build_config(curriculum, pi_weights=pi_weights, num_learners=learners,
                          num_cpus_per_learner=cpus, num_gpus_per_learner=gpus)
    bundles = config.algo_class.default_resource_request(config).bundles
    main, *rest = bundles
    assert main.get("GPU", 0) == (0 if learners else gpus)
    asked = {key: value for key, value in (("CPU", cpus), ("GPU", gpus)) if value}
    assert rest == [asked] * learners  # Ray's bundles leave out what is 0
    shards = max(learners, 1)
    assert config.num_learners == learners
    assert config.minibatch_size == math.ceil(curriculum.ppo.minibatch_size / shards)
    assert config.train_batch_size_per_learner == math.ceil(
        curriculum.ppo.train_batch_size / shards)
    assert config.total_train_batch_size >= curriculum.ppo.train_batch_size


def test_a_run_asking_for_gpus_ray_lacks_is_refused(monkeypatch):
    import ray

    monkeypatch.setattr(ray, "available_resources", lambda: {"CPU": 8.0})
    check_gpus(RunSettings())  # asks for none
    with pytest.raises(ValueError, match=r"the run asks for 2 GPUs \(--num-learners 2 x "
                                         r"--num-gpus-per-learner 1\) and this machine's Ray"):
        check_gpus(RunSettings(num_learners=2, num_gpus_per_learner=1, num_cpus_per_learner=0))
    monkeypatch.setattr(ray, "available_resources", lambda: {"CPU": 3.0})
    with pytest.raises(ValueError, match=r"has 3 free CPUs; the run asks for 4 \(1 for the "
                                         r"algorithm's process, 2 for --num-learners 2, 1 for "
                                         r"--num-env-runners 1\): pass --num-env-runners 0"):
        check_cluster_fits(RunSettings(address="auto", num_learners=2, num_env_runners=1))


def test_vf_runs_under_bfloat16_on_the_cpu():
    assert vf_autocast("cpu")
    assert vf_autocast("cuda") == (torch.cuda.is_available() and torch.cuda.is_bf16_supported())


def _by_learner(results) -> list:
    """RLlib's results of a call on every learner, in the learners' order."""
    return sorted(results.result_or_errors, key=lambda result: result.actor_id or 0)


def _states(algo) -> list[dict]:
    """Every learner's module states and optimizer moments, as numpy."""
    return [result.get() for result in _by_learner(algo.learner_group.foreach_learner(
        lambda learner: {"rl_module": learner.module.get_state(),
                         "optimizer": learner._get_optimizer_state()}))]


def _flat(state, prefix=()) -> dict:
    if isinstance(state, dict):
        return {k: v for key, value in state.items()
                for k, v in _flat(value, (*prefix, str(key))).items()}
    if isinstance(state, list | tuple) and not any(isinstance(x, float | int) for x in state):
        return {k: v for i, value in enumerate(state)
                for k, v in _flat(value, (*prefix, str(i))).items()}
    return {prefix: np.asarray(state.cpu() if torch.is_tensor(state) else state)}


def _equal(a: dict, b: dict, only: str = "") -> bool:
    a, b = _flat(a), _flat(b)
    keys = [k for k in a if "/".join(k).startswith(only)]
    return keys and set(keys) <= set(b) and all(np.array_equal(a[k], b[k]) for k in keys)


def _moved(before: dict, after: dict, module: str, net: str) -> bool:
    a, b = before["rl_module"][module], after["rl_module"][module]
    return any(not np.array_equal(a[k], b[k]) for k in a if k.startswith(net + "."))


def _gradients(learner, mode: str) -> dict:
    """Gradients of a loss whose gradient is learner index + 1 on every trainable weight of
    the learner module and, on learner 1 alone, 4 on the exploiter's ("mixed"); learner 1
    without any loss ("alone"); or "mixed" with an inf on learner 1's last learner weight,
    applied ("poison"). Per module: the distinct values, or None."""
    index = learner._learner_index
    weights = {mid: [p for p in learner.module[mid].parameters() if p.requires_grad]
               for mid in (LEARNER, EXPLOITER)}
    losses = {LEARNER: sum((p * (index + 1)).sum() for p in weights[LEARNER])}
    if index == 1:
        losses[EXPLOITER] = sum((p * 4).sum() for p in weights[EXPLOITER])
        if mode == "poison":
            losses[LEARNER] = losses[LEARNER] + weights[LEARNER][-1].sum() * math.inf
        elif mode == "alone":
            losses = {}
    gradients = learner.compute_gradients(losses)
    if mode == "poison":
        learner.apply_gradients(gradients)  # skipped on every learner
    return {mid: sorted({x for p in group if p.grad is not None
                         for x in p.grad.unique().tolist()}) or None
            for mid, group in weights.items()}


def _minibatches(learner) -> tuple[int, bool]:
    """How many minibatches each learner takes of an update where learner 0 holds 300 rows of
    the learner module and learner 1 only rows of a fixed seat, 2 epochs; whether they are
    empty."""
    from ray.rllib.core.learner.training_data import TrainingData
    from ray.rllib.policy.sample_batch import MultiAgentBatch, SampleBatch

    module, rows = (LEARNER, 300) if learner._learner_index == 0 else ("static", 50)
    batch = MultiAgentBatch({module: SampleBatch({"x": np.zeros(rows, np.float32)})}, rows)
    batches = learner._create_iterator_if_necessary(
        training_data=TrainingData(batch=batch), num_epochs=2,
        minibatch_size=learner.config.minibatch_size)
    if isinstance(batches, list):
        return len(batches), all(not b.policy_batches for b in batches)
    return batches._num_total_minibatches, False


def _fail_on_one(learner):
    """An update that fails on learner 1 before its first all-reduce; learner 0's goes on to
    it."""
    from ray.rllib.core.learner.training_data import TrainingData
    from ray.rllib.policy.sample_batch import MultiAgentBatch, SampleBatch

    if learner._learner_index == 1:
        learner.before_gradient_based_update = lambda **kwargs: 1 / 0
    batch = MultiAgentBatch({LEARNER: SampleBatch({"x": np.zeros(300, np.float32)})}, 300)
    learner.update(training_data=TrainingData(batch=batch), minibatch_size=64)


def _on_both(algo, func) -> list:
    """`func` on both learners, within 5 minutes (a learner left alone in an all-reduce would
    wait for ever)."""
    results = algo.learner_group.foreach_learner(func, timeout_seconds=300)
    values = [result.get() for result in _by_learner(results)]
    assert len(values) == 2, "a learner did not answer: the learners' all-reduces parted"
    return values


@pytest.mark.timeout(1800)  # three algorithms, two of them with learner actors, on a busy box
def test_two_learners_keep_one_set_of_weights_and_one_league(ray_session, pi_weights,
                                                             tmp_path):
    path = tmp_path / "learners_smoke.toml"
    path.write_text(LEARNERS_SMOKE)
    curriculum = load_curriculum(path)
    league = curriculum.league
    algo = build_config(curriculum, pi_weights=pi_weights, **TWO_LEARNERS).build_algo()
    try:
        assert len(algo.learner_group) == 2
        states = _states(algo)
        assert _equal(*states)  # learner 0's start on both (vf and exploiter drawn at random)

        # Gradients averaged over the learners that computed one (pi frozen: vf's alone)
        assert _on_both(algo, lambda learner: _gradients(learner, "mixed")) == [
            {LEARNER: [1.5], EXPLOITER: [4.0]}] * 2
        assert _on_both(algo, lambda learner: _gradients(learner, "alone")) == [
            {LEARNER: [1.0], EXPLOITER: None}] * 2
        poisoned = _on_both(algo, lambda learner: _gradients(learner, "poison"))
        assert all(math.inf in values[LEARNER] for values in poisoned)
        assert _equal(states[0], _states(algo)[1], "rl_module")  # skipped on both
        # one count of minibatches for the rows of all (ceil(2 x 300 / 128)), empty ones where
        # a learner holds no rows of a module it trains
        assert _on_both(algo, _minibatches) == [(5, False), (5, True)]

        results, filled_at = [], None
        while filled_at is None or len(results) < filled_at + 2:
            before = _states(algo)[0]
            result = algo.train()
            states = _states(algo)
            assert _equal(*states), f"the learners' weights parted at iteration {len(results)}"
            stage = result["curriculum"]["iteration_stage_name"]
            moved_pi = _moved(before, states[0], LEARNER, "pi")
            assert moved_pi == (stage == "league"), (stage, moved_pi)  # frozen in the warm-up
            assert _moved(before, states[0], LEARNER, "vf")
            trained = result["learners"][LEARNER]["num_module_steps_trained"]
            sampled = result["env_runners"]["num_module_steps_sampled"][LEARNER]
            assert sampled <= trained < 1.5 * sampled + 128, (trained, sampled)
            if result.get("league", {}).get("filled") and filled_at is None:
                filled_at = len(results)
                rl_module = states[0]["rl_module"]
                assert all(np.array_equal(value, rl_module[LEARNER][key])
                           for key, value in rl_module[result["league"]["filled"]].items()
                           if key.startswith("pi."))
            results.append(result)
            assert len(results) < 8, "the gate never filled a slot"
        assert results[0]["learners"][LEARNER]["nonfinite_updates_skipped"] == 1  # once, not twice
        league_results = results[filled_at:]
        assert sum(r["learners"].get(EXPLOITER, {}).get("num_module_steps_trained", 0)
                   for r in league_results) > 0  # its rows in one learner's shard or both
        assert all("pi_dual_clipped_rows" in r["learners"][LEARNER] for r in league_results)
        assert all("learner_kills" in r["env_runners"] for r in league_results)
        assert "matchmaking" in results[-1]
        books = _on_both(algo, lambda learner: (read_book(learner, league),
                                                learner.module[MATCHMAKING_MODULE].get_state()))
        assert books[0][0] == books[1][0] and books[0][0][0].filled
        assert _equal(books[0][1], books[1][1]) and books[0][1]["results"].sum() > 0
        runner = algo.env_runner.module["snapshot_0"].get_state()
        assert all(np.array_equal(v, states[0]["rl_module"]["snapshot_0"][k])
                   for k, v in runner.items())
        saved, book = states[0], books[0][0]
        two = algo.save_to_path(str(tmp_path / "two_learners"))

        # A learner that fails takes the other down with it instead of leaving it waiting.
        failed = _by_learner(algo.learner_group.foreach_learner(_fail_on_one,
                                                                timeout_seconds=300))
        assert [result.ok for result in failed] == [False, False]
        assert "division by zero" in str(failed[1].get())
    finally:
        algo.stop()

    # 2 learners -> the learner in the algorithm's process and a remote env runner
    algo = build_config(curriculum, pi_weights=pi_weights, num_env_runners=1,
                        cpus_per_env_runner=1.0, restore_from=two).build_algo()
    try:
        (local,) = _states(algo)
        assert _equal(saved, local)
        assert read_book(algo.learner_group._learner, league) == book
        mapping = algo.env_runner_group.foreach_env_runner(
            lambda runner: runner.config.policy_mapping_fn.opponent, local_env_runner=False)
        filled = members(book)  # on the runner's mapping at once
        assert filled and [opponent[-len(filled):] for opponent in mapping] == [filled]
        result = algo.train()
        assert result["training_iteration"] == len(results) + 1
        saved = _states(algo)[0]
        zero = algo.save_to_path(str(tmp_path / "zero_learners"))
    finally:
        algo.stop()

    # and back: 0 learners -> 2
    algo = build_config(curriculum, pi_weights=pi_weights, restore_from=zero,
                        **TWO_LEARNERS).build_algo()
    try:
        restored = _states(algo)
        assert _equal(saved, restored[0]) and _equal(saved, restored[1])
        books = _on_both(algo, lambda learner: read_book(learner, league))
        assert books[0] == books[1] and books[0][0].filled
    finally:
        algo.stop()


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
def test_a_gpu_learner_holds_its_modules_on_the_gpu_and_its_checkpoint_moves_to_a_cpu(
        ray_session, pi_weights, tmp_path):
    curriculum = load_curriculum("smoke")
    algo = build_config(curriculum, pi_weights=pi_weights, num_gpus_per_learner=1).build_algo()
    try:
        learner = algo.learner_group._learner
        devices = {mid: {p.device.type for p in module.parameters()}
                   for mid, module in learner.module.items()
                   if isinstance(module, torch.nn.Module)}
        assert devices and all(found == {"cuda"} for found in devices.values()), devices
        assert {p.device.type for p in algo.env_runner.module[LEARNER].parameters()} == {"cpu"}
        assert not torch.backends.cudnn.allow_tf32
        algo.train()
        saved = _states(algo)[0]
        checkpoint = algo.save_to_path(str(tmp_path / "gpu"))
    finally:
        algo.stop()
    algo = build_config(curriculum, pi_weights=pi_weights, restore_from=checkpoint).build_algo()
    try:
        assert _equal(saved, _states(algo)[0], "rl_module")
    finally:
        algo.stop()


TINY = """
name = "learners_tiny"
description = "Test-sized: one stage of 8 games."
max_steps = 40
[ppo]
train_batch_size = 320
num_epochs = 1
num_envs_per_env_runner = 4
checkpoint_every = 1
[defaults]
teammate = "suicide"
[[stage]]
name = "static"
opponent = "static"
episodes = 8
"""


def _train(*args, cwd):
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-m", "rllib_pommer.train", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=900)


@pytest.mark.timeout(2400)
def test_a_run_of_two_learners_packs_exports_and_resumes_with_none(tmp_path, pi_weights):
    """`train --num-learners 2` end to end: Tune places the learners on our own 2-CPU Ray, the
    trial's config says so, `--pack` and `--export` read its checkpoint as any other, and
    `--resume` goes on from it with the learner in the algorithm's process and an env runner."""
    import json

    from rllib_pommer.runs.checkpoints import latest_checkpoint, load_checkpoint_net
    from rllib_pommer.runs.history import legs, read_rows

    curriculum, run = tmp_path / "tiny.toml", tmp_path / "run"
    curriculum.write_text(TINY)
    first = _train("--curriculum", str(curriculum), "--out", str(run), "--pi-weights",
                   str(pi_weights), "--num-learners", "2", "--num-cpus-per-learner", "0.5",
                   cwd=tmp_path)
    assert first.returncode == 0 and "done: " in first.stdout, first.stderr[-3000:]
    (trial,) = run.glob("PPO_*")
    params = json.loads((trial / "params.json").read_text())
    assert (params["num_learners"], params["num_cpus_per_learner"]) == (2, 0.5)
    assert (params["minibatch_size"], params["_train_batch_size_per_learner"]) == (64, 160)

    packed = _train("--out", str(run), "--pack", cwd=tmp_path)
    assert packed.returncode == 0, packed.stderr[-3000:]
    checkpoint = latest_checkpoint(run)
    exported = _train("--out", str(run), "--export", str(tmp_path / "policies" / "two"),
                      cwd=tmp_path)
    assert exported.returncode == 0, exported.stderr[-3000:]
    shipped = torch.load(tmp_path / "policies" / "two" / "pi.pt", weights_only=True)
    trained = load_checkpoint_net(checkpoint).state_dict()
    assert shipped.keys() == trained.keys()
    assert all(torch.equal(shipped[k], trained[k]) for k in trained)

    resumed = _train("--out", str(run), "--resume", "--num-env-runners", "1", cwd=tmp_path)
    assert resumed.returncode == 0 and "done: " in resumed.stdout, resumed.stderr[-3000:]
    leg = max(run.glob("PPO_*"), key=lambda path: len(legs(path)))
    assert legs(leg) == [trial, leg]
    params = json.loads((leg / "params.json").read_text())
    assert (params["num_learners"], params["num_env_runners"]) == (0, 1)
    assert params["minibatch_size"] == 128
    iterations = [int(float(row["training_iteration"])) for row in read_rows(leg)]
    assert iterations == list(range(1, len(iterations) + 1)) and len(iterations) > 1


def test_the_gpu_benchmark_runs_its_steps_on_cpus(tmp_path):
    """`benchmarks/gpu_learner.py --dry-run`: the league curriculum with the "GPU" learner on the
    CPU, its checkpoint moved to a CPU run with every weight equal, both learners timed."""
    import json
    import subprocess
    import sys

    out = tmp_path / "gpu_learner.json"
    done = subprocess.run([sys.executable, str(REPO / "benchmarks" / "gpu_learner.py"),
                           "--dry-run", "--out", str(out)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    figures = json.loads(out.read_text())
    assert figures["dry_run"] and figures["weights_equal_on_cpu"]
    assert figures["arrays_compared"] > 20 and figures["learner_devices"] == ["cpu"]
    assert figures["gpu_learner_samples_per_s"] > 0 and figures["cpu_learner_samples_per_s"] > 0
    assert "all equal" in done.stdout
