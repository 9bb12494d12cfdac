"""Hostile checkpoints and training runs: foreign, damaged or tampered checkpoints, a resume with other
settings, an existing run folder, bad YAML values and data that never moves."""

import csv
import shutil
from pathlib import Path

import pytest
import torch
import yaml
from hostile import cli, refused, tree_digest

from flowvo.model.checkpoint import read_checkpoint, save_checkpoint
from flowvo.model.config import ModelConfig, TrainConfig
from flowvo.model.train import train
from flowvo.synth.dataset import synthesize


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("ckpt") / "data"
    synthesize(root, ["00", "01"], seed=6, frames=12, scale=0.15, workers=1)
    still = root.parent / "still.txt"
    still.write_text("1 0 0 0 0 1 0 0 0 0 1 0\n" * 12)
    synthesize(root, ["05"], trajectory=still, scale=0.15, workers=1, force=True)
    return root


def tiny_config(data: Path, out: Path, **changes) -> TrainConfig:
    config = TrainConfig(data=str(data), train_sequences=["00"], val_sequences=["01"], flow_method="dis-ultrafast",
                         flow_scale=1.0, model=ModelConfig(width=0.125, input_hw=(32, 96), fc_units=32), epochs=2,
                         batch_size=8, out=str(out))
    for key, value in changes.items():
        setattr(config, key, value)
    return config


@pytest.fixture(scope="module")
def trained(data, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("trained") / "run"
    train(tiny_config(data, out))
    return out


@pytest.fixture
def run_copy(trained, tmp_path) -> Path:
    return Path(shutil.copytree(trained, tmp_path / "run"))


def tampered(path: Path, out: Path, change) -> Path:
    state = read_checkpoint(path)
    change(state)
    save_checkpoint(out, {k: v for k, v in state.items() if k != "format"})
    return out


TAMPERING = {
    "extra model option": (lambda s: s["model_config"].update(attention=True), "does not know: attention"),
    "invalid model option": (lambda s: s["model_config"].update(stack=0), "model stack must be in [1"),
    "no normalisation": (lambda s: s.pop("normalization"), "lacks normalization"),
    "NaN normalisation": (lambda s: s["normalization"].update(flow_std_px=float("nan")), "NaN, infinite"),
    "short normalisation": (lambda s: s["normalization"].update(target_mean=[0.0]), "2 values per target"),
    "other weights": (lambda s: s["model_state"].pop(next(iter(s["model_state"]))), "weights do not fit"),
}


@pytest.mark.parametrize("tampering", TAMPERING)
def test_run_refuses_a_tampered_checkpoint(data, trained, tmp_path, capsys, tampering):
    change, message = TAMPERING[tampering]
    model = tampered(trained / "best.pt", tmp_path / "model.pt", change)
    refused(capsys, "run", "--data", data, "--sequence", "01", "--method", "cnn", "--model", model,
            "--out", tmp_path / "out",
            says=(str(model), message))
    assert not (tmp_path / "out" / "01.txt").exists()


FOREIGN = {
    "truncated": (lambda p, src: p.write_bytes(src.read_bytes()[:2000]), "cannot read as a PyTorch checkpoint"),
    "text": (lambda p, src: p.write_text("weights"), "cannot read as a PyTorch checkpoint"),
    "a list": (lambda p, src: torch.save([1, 2], p), "not a flowvo odometry checkpoint"),
    "folder": (lambda p, src: p.mkdir(), "model checkpoint not found"),
}


@pytest.mark.parametrize("kind", FOREIGN)
def test_run_and_export_refuse_a_foreign_checkpoint(data, trained, tmp_path, capsys, kind):
    make, message = FOREIGN[kind]
    model = tmp_path / "model.pt"
    make(model, trained / "best.pt")
    refused(capsys, "run", "--data", data, "--sequence", "01", "--method", "cnn", "--model", model,
            "--out", tmp_path / "o",
            says=message)
    refused(capsys, "export", "--model", model, "--out", tmp_path / "m.ts", says=message)
    assert not (tmp_path / "m.ts").exists()


def test_train_into_an_existing_run_is_refused_without_resume_or_force(data, run_copy, capsys):
    before = tree_digest(run_copy)
    refused(capsys, "train", "--data", data, "--train", "00", "--val", "01", "--out", run_copy,
            says=("holds an earlier result", "best.pt", "--force"))
    assert tree_digest(run_copy) == before


@pytest.mark.parametrize("change, message", [
    (["--lr", "0.01"], "learning_rate=0.01 (the run has 0.001)"),
    (["--batch-size", "4"], "batch_size=4 (the run has 8)"),
    (["--epochs", "5"], "epochs=5 (the run has 2)"),
    (["--train", "01"], "train_sequences=['01']"),
    (["--flow-scale", "0.5"], "flow_scale=0.5"),
    (["--width", "0.25"], "different architecture: width=0.125"),
])
def test_resume_with_other_settings_is_refused_and_changes_nothing(run_copy, capsys, change, message):
    before = tree_digest(run_copy)
    refused(capsys, "train", "--out", run_copy, "--resume", *change, says=message)
    assert tree_digest(run_copy) == before


def test_resume_alone_keeps_the_runs_own_settings(run_copy, capsys):
    config = yaml.safe_load((run_copy / "config.yaml").read_text())
    code, out, _ = cli(capsys, "train", "--out", run_copy, "--resume")
    assert code == 0 and "training finished" in out  # nothing left to do: 2 of 2 epochs done
    assert yaml.safe_load((run_copy / "config.yaml").read_text()) == {**config, "out": str(run_copy)}


def test_resume_from_a_slim_checkpoint_is_refused(run_copy, capsys):
    assert cli(capsys, "export", "--model", run_copy / "last.pt", "--out", run_copy / "slim.pt", "--format",
               "slim")[0] == 0
    shutil.move(run_copy / "slim.pt", run_copy / "last.pt")
    refused(capsys, "train", "--out", run_copy, "--resume", says=("last.pt", "slim checkpoint can be run, not resumed"))


def test_resume_and_force_together_are_refused(run_copy, capsys):
    refused(capsys, "train", "--out", run_copy, "--resume", "--force", says="give one of them")


def test_force_starts_the_run_over(data, run_copy):
    train(tiny_config(data, run_copy, epochs=1), force=True)
    assert [row["epoch"] for row in csv.DictReader(open(run_copy / "log.csv"))] == ["1"]
    assert read_checkpoint(run_copy / "best.pt")["epoch"] == 0


def test_training_on_a_camera_that_never_moves_is_refused(data, tmp_path, capsys):
    refused(capsys, "train", "--data", data, "--train", "05", "--val", "01", "--out", tmp_path / "run",
            "--flow-method", "dis-ultrafast", "--flow-scale", "1", says=("05", "moves 0 m", "nothing to learn"))
    assert not (tmp_path / "run" / "best.pt").exists()


@pytest.mark.parametrize("yaml_text, message", [
    ("epochs: ten", "epochs must be an integer, got 'ten'"),
    ("batch_size: 1.5", "batch_size must be an integer"),
    ("learning_rate: .nan", "learning_rate must be in"),
    ("model: {stack: 0}", "model stack must be in [1"),
    ("model: [1, 2]", "model must be a mapping"),
    ("val_sequences: []", "val_sequences must be a non-empty list"),
    ("train_sequences: ['../00']", "is a path"),
    ("loss_weights: [1.0]", "loss_weights must list 2 numbers"),
    ("schedule: warmup", "schedule must be 'cosine' or 'constant'"),
    ("epochs: [", "not valid YAML"),
    ("\udcff\udcfe", "not valid YAML (not UTF-8 text)"),
    ("dropout_rate: 0.2", "unknown training option(s): dropout_rate"),
])
def test_bad_yaml_values_are_refused_naming_the_file(data, tmp_path, capsys, yaml_text, message):
    (tmp_path / "c.yaml").write_bytes((yaml_text + "\n").encode("utf-8", "surrogateescape"))
    refused(capsys, "train", "--config", tmp_path / "c.yaml", "--data", data, "--out", tmp_path / "run",
            says=("c.yaml", message))
    assert not (tmp_path / "run").exists()
