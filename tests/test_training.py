import csv
import os
import subprocess
import sys

import numpy as np
import pytest
import torch

from flowvo.cli import main
from flowvo.model.checkpoint import read_checkpoint
from flowvo.model.config import ModelConfig, TrainConfig
from flowvo.model.train import train
from flowvo.synth.dataset import synthesize


@pytest.fixture(scope="module")
def tiny_data(tmp_path_factory):
    root = tmp_path_factory.mktemp("tiny")
    synthesize(root, ["00", "01", "02"], seed=5, frames=40, scale=0.25, workers=1)
    return root


def tiny_config(root, out, epochs=3) -> TrainConfig:
    return TrainConfig(
        data=str(root), train_sequences=["00", "01"], val_sequences=["02"], flow_method="dis-ultrafast",
        flow_scale=1.0, model=ModelConfig(width=0.125, input_hw=(32, 96), fc_units=128), epochs=epochs,
        batch_size=16, out=str(out), early_stopping_patience=10,
    )


def test_resume_gives_the_same_model_as_an_uninterrupted_run(tiny_data, tmp_path):
    train(tiny_config(tiny_data, tmp_path / "straight"))
    train(tiny_config(tiny_data, tmp_path / "resumed"), stop_after_epochs=1)
    assert read_checkpoint(tmp_path / "resumed" / "last.pt")["epoch"] == 0
    train(tiny_config(tiny_data, tmp_path / "resumed"), resume=True)
    a = read_checkpoint(tmp_path / "straight" / "last.pt")
    b = read_checkpoint(tmp_path / "resumed" / "last.pt")
    assert a["epoch"] == b["epoch"] == 2
    for key, value in a["model_state"].items():
        assert torch.equal(value, b["model_state"][key]), key
    rows = list(csv.DictReader(open(tmp_path / "resumed" / "log.csv")))
    assert [int(r["epoch"]) for r in rows] == [1, 2, 3]
    assert (tmp_path / "resumed" / "learning_curve.png").is_file()
    assert (tmp_path / "resumed" / "config.yaml").is_file()


def test_training_reduces_the_loss_and_logs_kitti_errors(tiny_data, tmp_path):
    train(tiny_config(tiny_data, tmp_path, epochs=4))
    rows = list(csv.DictReader(open(tmp_path / "log.csv")))
    losses = [float(r["train_loss"]) for r in rows]
    assert losses[-1] < losses[0]
    assert all(np.isfinite(float(r["val_loss"])) for r in rows)
    assert "val_t_err_percent" in rows[0]


def test_train_and_run_from_the_cli(tiny_data, tmp_path, capsys):
    config = tiny_config(tiny_data, tmp_path / "run", epochs=1)
    config.save_yaml(tmp_path / "c.yaml")
    assert main(["train", "--config", str(tmp_path / "c.yaml"), "-q"]) == 0
    assert "M parameters" in capsys.readouterr().out
    assert main(["run", "--data", str(tiny_data), "--sequence", "02", "--method", "cnn",
                 "--model", str(tmp_path / "run/best.pt"), "--out", str(tmp_path / "out"), "-q"]) == 0
    printed = capsys.readouterr().out
    assert "(synthetic)" in printed
    poses = np.loadtxt(tmp_path / "out" / "02.txt")
    assert poses.shape == (40, 12)
    assert (tmp_path / "out" / "02.tum").is_file() and (tmp_path / "out" / "timing.json").is_file()
    assert main(["export", "--model", str(tmp_path / "run/best.pt"), "--out", str(tmp_path / "m.ts")]) == 0
    scripted = torch.jit.load(str(tmp_path / "m.ts"))
    assert scripted(torch.zeros(1, 2, 32, 96)).shape == (1, 2)
    assert main(["export", "--model", str(tmp_path / "run/best.pt"), "--out", str(tmp_path / "slim.pt"),
                 "--format", "slim"]) == 0
    assert (tmp_path / "slim.pt").stat().st_size < (tmp_path / "run/best.pt").stat().st_size / 2
    assert main(["run", "--data", str(tiny_data), "--sequence", "02", "--method", "cnn",
                 "--model", str(tmp_path / "slim.pt"), "--out", str(tmp_path / "out_slim"), "-q"]) == 0
    full, slim = np.loadtxt(tmp_path / "out" / "02.txt"), np.loadtxt(tmp_path / "out_slim" / "02.txt")
    assert np.abs(full - slim).max() < 0.5  # float16 weights, same trajectory to within rounding drift


def test_resume_with_another_architecture_is_refused(tiny_data, tmp_path, capsys):
    train(tiny_config(tiny_data, tmp_path, epochs=1))
    other = tiny_config(tiny_data, tmp_path, epochs=2)
    other.model.input_hw = (64, 192)
    other.save_yaml(tmp_path / "c.yaml")
    assert main(["train", "--config", str(tmp_path / "c.yaml"), "--resume", "-q"]) == 2
    assert "different architecture: input_hw=(32, 96)" in capsys.readouterr().err


def test_distributed_training_with_two_cpu_processes(tiny_data, tmp_path):
    config = tiny_config(tiny_data, tmp_path / "ddp", epochs=2)
    config.save_yaml(tmp_path / "c.yaml")
    env = {**os.environ, "FLOWVO_PROGRESS": "0", "OMP_NUM_THREADS": "1"}
    result = subprocess.run(
        [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node=2",
         "-m", "flowvo.cli", "train", "--config", str(tmp_path / "c.yaml")],
        capture_output=True, text=True, env=env, timeout=300,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    rows = list(csv.DictReader(open(tmp_path / "ddp" / "log.csv")))
    assert len(rows) == 2
