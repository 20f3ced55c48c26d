"""Behaviour cloning on a tiny dataset: it learns, resumes exactly, and its policy plays."""

from __future__ import annotations

import json
import pickle
import warnings

import numpy as np
import pytest
import torch

from rllib_pommer.data.collector import Collection
from rllib_pommer.data.dataset import open_dataset
from rllib_pommer.evaluate import main as evaluate_main
from rllib_pommer.imitation import bc
from rllib_pommer.imitation.bc import BCConfig, evaluate, train, write_policy_file
from rllib_pommer.imitation.learned import load_policy_net
from rllib_pommer.imitation.network import PommerNet
from rllib_pommer.rl.config import check_weights


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("expert")
    Collection(out, 8, 3, 4, label_draws=8).run(workers=1)
    return out


def _config(dataset, out, **overrides) -> BCConfig:
    options = dict(data=dataset, out=out, epochs=1, batch_size=64, lr=3e-3, dropout=0.0,
                   val_fraction=0.25, threads=1, checkpoint_every=20, max_batches_per_epoch=60,
                   max_val_batches=None)
    options.update(overrides)
    return BCConfig(**options)


def test_one_epoch_lowers_the_validation_loss(dataset, tmp_path):
    cfg = _config(dataset, tmp_path / "policy")
    _, val = open_dataset(dataset).split(cfg.val_fraction, cfg.seed)
    torch.manual_seed(cfg.seed)
    before = evaluate(PommerNet(), val, cfg)
    metrics = train(cfg)
    assert metrics["validation_loss"] < before["loss"] - 0.1
    assert metrics["validation_accuracy"] > before["accuracy"]
    assert metrics["validation_expected_agreement"] > before["expected_agreement"] + 0.1
    assert 0 < metrics["validation_mode_accuracy"] <= 1
    saved = json.loads((cfg.out / bc.METRICS_FILE).read_text())
    assert saved["validation_samples"] == metrics["validation_samples"] > 0


def test_soft_targets_count_the_recorded_action_as_one_more_draw():
    counts = np.array([[0, 0, 0, 0, 0, 0], [2, 0, 0, 1, 0, 0]], np.uint8)
    targets = bc.soft_targets(np.array([4, 3]), counts)
    assert np.allclose(targets, [[0, 0, 0, 0, 1, 0], [0.5, 0, 0, 0.5, 0, 0]])


@pytest.mark.parametrize("fast", [False, True])
def test_fast_settings_train_the_same_network(dataset, tmp_path, fast):
    """channels_last and bf16 autocast change speed, not what is learned: both builds learn and
    write plain contiguous weights that load into a fresh PommerNet."""
    cfg = _config(dataset, tmp_path / "fast", channels_last=fast, bf16=fast)
    metrics = train(cfg)
    assert metrics["validation_loss"] < np.log(6) - 0.15  # an untrained net scores ~log(6)
    weights = torch.load(cfg.out / bc.WEIGHTS_FILE, weights_only=True)
    assert all(w.is_contiguous() for w in weights.values())
    PommerNet().load_state_dict(weights)


def test_an_interrupted_run_resumes_to_the_same_weights(dataset, tmp_path, monkeypatch):
    straight = _config(dataset, tmp_path / "straight", epochs=2)
    train(straight)
    resumed = _config(dataset, tmp_path / "resumed", epochs=2)
    real_save = bc._Checkpoint.save

    def save_then_die(self, net, optimizer, epoch, batch, seconds):
        real_save(self, net, optimizer, epoch, batch, seconds)
        if epoch == 1 and batch == 40:
            raise KeyboardInterrupt  # as if killed right after this checkpoint

    monkeypatch.setattr(bc._Checkpoint, "save", save_then_die)
    with pytest.raises(KeyboardInterrupt):
        train(resumed)
    monkeypatch.setattr(bc._Checkpoint, "save", real_save)
    train(resumed)
    a = torch.load(straight.out / bc.WEIGHTS_FILE, weights_only=True)
    b = torch.load(resumed.out / bc.WEIGHTS_FILE, weights_only=True)
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_the_saved_policy_loads_and_plays_in_the_arena(dataset, tmp_path, capsys):
    out = tmp_path / "policies" / "tiny"
    train(_config(dataset, out, max_batches_per_epoch=5))
    policy = write_policy_file(out, "tiny test policy")
    assert evaluate_main(["--team", str(policy), "--vs", "static", "--games", "4",
                          "--workers", "1", "--filters", "action", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["games"] == 4 and summary["team"] == str(policy)


def test_bad_weights_files_are_named(tmp_path):
    with pytest.raises(ValueError, match="missing.pt: weights file not found"):
        load_policy_net(tmp_path / "missing.pt")
    corrupt = tmp_path / "corrupt.pt"
    corrupt.write_bytes(b"not a torch file")
    with pytest.raises(ValueError, match="corrupt.pt: not a readable weights file"):
        load_policy_net(corrupt)
    wrong = tmp_path / "value_net.pt"
    torch.save(PommerNet(num_outputs=1).state_dict(), wrong)
    with pytest.raises(ValueError, match="value_net.pt: weights do not fit PommerNet"):
        load_policy_net(wrong)


@pytest.mark.parametrize("content", [
    pickle.dumps(object),  # a pickle torch will not load without running code
    b"not a torch file",
    b"PK\x03\x04 cut short",  # the start of torch's zip format
], ids=["pickle", "text", "cut_zip"])
def test_an_unreadable_weights_file_is_one_line_without_torchs_advice(tmp_path, content):
    """Issue 50, case 29: torch's paragraphs (load with weights_only=False, file an issue) do
    not follow our line, and no warning of torch's precedes it."""
    path = tmp_path / "pi.pt"
    path.write_bytes(content)
    with pytest.raises(ValueError) as info, warnings.catch_warnings(record=True) as warned:
        warnings.simplefilter("always")
        load_policy_net(path)
    assert [str(w.message) for w in warned] == []
    message = str(info.value)
    assert message.startswith(f"{path}: not a readable weights file, a state_dict of tensors (")
    assert "\n" not in message and "weights_only" not in message and "issue" not in message


def test_a_folder_given_as_weights_is_named_a_folder(tmp_path):
    """Issue 50, case 30: a folder exists, so "not found" would send the user looking for it."""
    with pytest.raises(ValueError, match=f"^{tmp_path}: a folder, not a weights file$"):
        load_policy_net(tmp_path)
    with pytest.raises(ValueError, match=f"^{tmp_path}: a folder, not a weights file$"):
        check_weights(tmp_path)


def test_the_learning_rate_decays_by_a_cosine_to_its_floor(tmp_path):
    cfg = BCConfig(data=tmp_path, out=tmp_path, lr=1e-3, final_lr_fraction=0.1)
    rates = [bc.learning_rate(cfg, step, 101) for step in range(101)]
    assert rates[0] == pytest.approx(1e-3) and rates[-1] == pytest.approx(1e-4)
    assert rates[50] == pytest.approx(5.5e-4) and all(np.diff(rates) <= 0)
    flat = BCConfig(data=tmp_path, out=tmp_path, lr_decay=False)
    assert bc.learning_rate(flat, 100, 101) == flat.lr


def test_init_starts_from_given_weights_and_several_datasets_train_together(dataset, tmp_path):
    start = PommerNet()
    torch.nn.init.constant_(start.head[-1].bias, 0.5)
    torch.save(start.state_dict(), tmp_path / "start.pt")
    cfg = _config([dataset, dataset], tmp_path / "tuned", init=tmp_path / "start.pt", lr=1e-12,
                  max_batches_per_epoch=2)
    metrics = train(cfg)
    tuned = torch.load(cfg.out / bc.WEIGHTS_FILE, weights_only=True)
    assert torch.allclose(tuned["head.3.bias"], torch.full((6,), 0.5), atol=1e-6)
    single = open_dataset(dataset).split(cfg.val_fraction, cfg.seed)[0].num_samples
    assert metrics["train_samples"] == 2 * single
    assert json.loads((cfg.out / bc.METRICS_FILE).read_text())["config"]["data"] == [
        str(dataset)] * 2


def test_fewer_draws_subsample_each_rows_draws_without_replacement():
    rng = np.random.default_rng(0)
    counts = np.array([[16, 0, 0, 0, 0, 0], [8, 0, 8, 0, 0, 0], [0] * 6, [1, 1, 1, 0, 0, 0]],
                      np.uint8)
    picked = np.stack([bc.fewer_draws(counts, 4, rng) for _ in range(2000)])
    assert (picked.sum(2) == [4, 4, 0, 3]).all()  # a row with fewer draws keeps them all
    assert (picked <= counts).all() and (picked[:, 0, 0] == 4).all()
    assert abs(picked[:, 1, 0].mean() - 2.0) < 0.1  # half of 4 from an even split
    assert np.array_equal(picked[:, 3], np.broadcast_to(counts[3], (2000, 6)))


def test_imitate_never_replaces_a_policy_it_did_not_train_without_force(dataset, tmp_path,
                                                                        capsys):
    """A shipped policy's folder given as --out (issue 40, case 2): refused, nothing touched;
    --force replaces it; a re-run of the command that trained it resumes without --force."""
    from rllib_pommer.imitate import main

    shipped = tmp_path / "policies" / "imitation_v1"
    shipped.mkdir(parents=True)
    torch.save(PommerNet().state_dict(), shipped / "pi.pt")
    (shipped / "metrics.json").write_text("{}")
    write_policy_file(shipped, "the shipped clone")
    before = {p.name: p.read_bytes() for p in (shipped / "pi.pt", shipped / "metrics.json",
                                               shipped.with_suffix(".toml"))}
    args = ["--data", str(dataset), "--out", str(shipped), "--max-batches-per-epoch", "2",
            "--batch-size", "64", "--threads", "1", "--val-fraction", "0.25"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.strip() == (f"error: --out {shipped}: {shipped / 'pi.pt'} exists (a policy not "
                           f"trained here); pass --force to replace it, or choose another --out")
    assert {p.name: p.read_bytes() for p in (shipped / "pi.pt", shipped / "metrics.json",
                                             shipped.with_suffix(".toml"))} == before
    (shipped / "pi.pt").unlink()  # the policy file alone is a policy too
    assert main(args) == 2 and "imitation_v1.toml exists" in capsys.readouterr().err
    assert main([*args, "--force"]) == 0
    assert "Behaviour cloning" in shipped.with_suffix(".toml").read_text()
    assert main(args) == 0  # its own training state: a re-run resumes
