"""Hostile numbers: zero, negative, NaN, infinite or absurd option values; the smallest valid inputs; and
numbers that must come out exact (RPE of identical poses, TUM timestamps, strict JSON)."""

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
from hostile import cli, refused

from flowvo.io.atomic import strict_json_dumps
from flowvo.kitti.poses import read_kitti_poses
from flowvo.metrics.trajectory_errors import per_frame_errors, rpe
from flowvo.synth.dataset import synthesize
from flowvo.trajectory import Trajectory

OUT_OF_RANGE = [  # (sub-command and required arguments, option, bad values)
    ("synth --out {tmp}/s", "--frames", ["0", "1", "-3", "x", "2.5"]),
    ("synth --out {tmp}/s", "--scale", ["0", "-1", "nan", "inf", "5"]),
    ("synth --out {tmp}/s", "--seed", ["-1"]),
    ("synth --out {tmp}/s", "--workers", ["0", "-2"]),
    ("synth --out {tmp}/s", "--max-speed", ["0", "-5", "1e9"]),
    ("synth --out {tmp}/s", "--ground-texture-scale", ["0", "-1", "nan", "inf", "5", "x"]),
    ("flow --data {data} --sequence 00", "--scale", ["0", "-0.5", "3", "nan"]),
    ("flow --data {data} --sequence 00 --visualize {tmp}/v", "--every", ["0", "-1"]),
    ("run --data {data} --sequence 00 --out {tmp}/r", "--max-frames", ["0", "1", "-3"]),
    ("run --data {data} --sequence 00 --out {tmp}/r", "--fx", ["x"]),
    ("run --data {data} --sequence 00 --out {tmp}/r", "--latency", ["-1", "101", "2.5", "nan"]),
    ("train --data {data}", "--epochs", ["0", "-1"]),
    ("train --data {data}", "--batch-size", ["0"]),
    ("train --data {data}", "--lr", ["0", "-1e-3", "nan", "inf"]),
    ("train --data {data}", "--width", ["0", "-1", "100"]),
    ("train --data {data}", "--stack", ["0", "99"]),
    ("train --data {data}", "--seed", ["-1"]),
    ("train --data {data}", "--flow-scale", ["0"]),
    ("bench --data {data} --sequence 00", "--frames", ["0", "1"]),
    ("bench --data {data} --sequence 00", "--repeat", ["0"]),
    ("demo --out {tmp}/d", "--frames", ["0", "1"]),
]
CASES = [(command, option, value) for command, option, values in OUT_OF_RANGE for value in values]


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("numbers") / "data"
    synthesize(root, ["00"], seed=3, frames=12, scale=0.1, workers=1)
    return root


@pytest.mark.parametrize("command, option, value", CASES, ids=[f"{c.split()[0]}{o}={v}" for c, o, v in CASES])
def test_out_of_range_numbers_are_refused_naming_the_option(data, tmp_path, capsys, command, option, value):
    args = [a.format(tmp=tmp_path, data=data) for a in command.split()]
    refused(capsys, *args, f"{option}={value}", says=f"argument {option}")
    assert list(tmp_path.iterdir()) == []


def test_two_frames_are_enough_for_synth_and_run(tmp_path, capsys):
    assert cli(capsys, "synth", "--out", tmp_path / "d", "--frames", "2", "--scale", "0.1", "--workers", "1")[0] == 0
    assert len(read_kitti_poses(tmp_path / "d" / "poses" / "00.txt")) == 2
    code, out, _ = cli(capsys, "run", "--data", tmp_path / "d", "--sequence", "00", "--out", tmp_path / "r",
                       "--method", "classical")
    assert code == 0 and "ATE" in out


def test_a_scale_giving_tiny_images_is_refused(tmp_path, capsys):
    refused(capsys, "synth", "--out", tmp_path, "--scale", "0.01", says=("--scale 0.01 gives 12x4 images",
                                                                          "at least 16"))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("method", ["dis-ultrafast", "dis-fast"])
def test_flow_too_small_for_opencv_is_refused_not_a_crash(data, tmp_path, capsys, method):
    # 124x38 frames at scale 0.5 give 62x19 flow: OpenCV's DIS ultrafast/fast would die of SIGSEGV
    refused(capsys, "flow", "--data", data, "--sequence", "00", "--method", method, "--cache", tmp_path,
            says=("flow scale 0.5 of 124x38 frames", "at least 32 pixels"))


@pytest.mark.skipif(torch.cuda.is_available(), reason="this machine has a GPU")
@pytest.mark.parametrize("command", ["train --data {data} --train 00 --val 00 --out {tmp}/t"])
def test_cuda_without_a_gpu_is_one_clear_line(data, tmp_path, capsys, command):
    args = [a.format(tmp=tmp_path, data=data) for a in command.split()]
    refused(capsys, *args, "--device", "cuda", says=("--device cuda", "no CUDA GPU", "--device cpu"))


@pytest.mark.parametrize("device", ["gpu", "cuda:x", "mps"])
def test_an_unknown_device_is_refused(data, tmp_path, capsys, device):
    refused(capsys, "train", "--data", data, "--train", "00", "--val", "00", "--out", tmp_path / "t",
            "--device", device,
            says=("--device", device))


def test_rpe_of_ground_truth_against_itself_is_exactly_zero(kitti_poses_dir):
    gt = read_kitti_poses(kitti_poses_dir / "09.txt")
    assert rpe(gt, gt) == {"rpe_trans_rmse_m": 0.0, "rpe_rot_rmse_deg": 0.0}


def test_rpe_resolves_tiny_rotation_errors_without_a_floor():
    poses = np.tile(np.eye(4), (3, 1, 1))
    poses[:, 2, 3] = [0.0, 1.0, 2.0]
    turned = poses.copy()
    angle = 1e-7  # rad, far below acos's resolution near 1 (1.5e-8 rad in double, 3e-4 in float32)
    turned[2, :3, :3] = [[math.cos(angle), 0, math.sin(angle)], [0, 1, 0], [-math.sin(angle), 0, math.cos(angle)]]
    errors = per_frame_errors(Trajectory.from_poses(poses), Trajectory.from_poses(turned))
    np.testing.assert_allclose(errors["rotation_error_deg"], [0.0, math.degrees(angle)], rtol=1e-6)


def test_tum_timestamps_come_from_times_txt(data, tmp_path, capsys):
    copy = Path(shutil.copytree(data, tmp_path / "d"))
    times = np.cumsum(np.r_[1000.0, np.linspace(0.09, 0.11, 11)])  # a real clock: offset, uneven steps
    (copy / "sequences/00/times.txt").write_text("".join(f"{t:.6f}\n" for t in times))
    code, _, _ = cli(capsys, "run", "--data", copy, "--sequence", "00", "--out", tmp_path / "r", "--method=classical")
    assert code == 0
    np.testing.assert_allclose(np.loadtxt(tmp_path / "r" / "00.tum")[:, 0], times, atol=1e-6)


def test_strict_json_writes_null_for_nan_and_infinity():
    text = strict_json_dumps({"t": math.nan, "r": [np.float32("inf"), -math.inf, 1.5], "n": np.int64(3)})
    assert json.loads(text) == {"t": None, "r": [None, None, 1.5], "n": 3}
