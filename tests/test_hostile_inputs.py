"""Hostile round two, the inputs: camera numbers (calib.txt P0, principal point near the border, frames too
narrow), timestamps (0_9, negative or beyond ROS time with --mcap, an hour's gap), a still image as a
video, eval's lengths and pose counts, export's formats and opsets, report's run.json and HTML, signals,
and --help defaults."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from hostile import cli, refused, tree_digest

from flowvo.odometry.speed_prior import SpeedPrior
from flowvo.synth.dataset import synthesize

SRC = Path(__file__).resolve().parents[1] / "src"
P0 = "P0: {fx} 0 60 0 0 {fy} 25 0 0 0 1 0\n"


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("inputs") / "data"
    synthesize(root, ["00"], seed=5, frames=8, scale=0.15, workers=1)
    return root


def copy_with(data: Path, tmp_path: Path, name: str, text: str) -> Path:
    """A copy of the dataset with one file of sequence 00 replaced by ``text``."""
    root = tmp_path / "copy"
    subprocess.run(["cp", "-r", str(data), str(root)], check=True)
    (root / "sequences" / "00" / name).write_text(text)
    return root


@pytest.mark.parametrize("fx, fy, says", [("nan", "100", "finite"), ("inf", "100", "finite"), ("0", "100", "positive"),
                                          ("-5", "100", "positive"), ("0", "0", "positive")])
def test_calib_p0_without_a_camera_is_refused_with_file_and_line(data, tmp_path, capsys, fx, fy, says):
    root = copy_with(data, tmp_path, "calib.txt", P0.format(fx=fx, fy=fy))
    refused(capsys, "run", "--data", root, "--sequence", "00", "--out", tmp_path / "o", "--method", "classical",
            says=("calib.txt:1", "P0", says))
    assert not (tmp_path / "o").exists()


def test_all_zero_p0_is_refused(data, tmp_path, capsys):
    root = copy_with(data, tmp_path, "calib.txt", "P0: " + " ".join(["0"] * 12) + "\n")
    refused(capsys, "run", "--data", root, "--sequence", "00", "--out", tmp_path / "o",
            says=("calib.txt:1", "positive"))


@pytest.mark.parametrize("name, text", [("times.txt", "0_9\n"), ("calib.txt", P0.format(fx="1_00", fy="100"))])
def test_digit_group_underscores_are_not_numbers(data, tmp_path, capsys, name, text):
    original = (data / "sequences" / "00" / name).read_text().splitlines(keepends=True)
    root = copy_with(data, tmp_path, name, text + "".join(original[1:]))
    refused(capsys, "run", "--data", root, "--sequence", "00", "--out", tmp_path / "o", "--method", "classical",
            says=f"{name}:1")


def video(path: Path, frames: int, width: int, height: int) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10, (width, height))
    rng = np.random.default_rng(0)
    for _ in range(frames):
        writer.write(rng.integers(0, 255, (height, width, 3), dtype=np.uint8))
    writer.release()
    return path


@pytest.mark.parametrize("cx, cy, says", [("300", "235", "no room for the road crop"),
                                          ("595", "100", "no room for the road crop"),
                                          ("300", "100", None), ("300", "140", None)])
def test_principal_point_without_room_for_the_road_is_one_line_before_writing(tmp_path, capsys, cx, cy, says):
    clip = video(tmp_path / "v.mp4", 3, 600, 240)
    args = ["run", "--video", clip, "--fx", "300", "--fy", "300", "--cx", cx, "--cy", cy, "--out", tmp_path / "o"]
    if says is None:
        assert cli(capsys, *args)[0] == 0
    else:
        refused(capsys, *args, says=(says, "600x240"))
        assert not (tmp_path / "o").exists()


def test_frames_narrower_than_the_default_methods_minimum_are_refused(tmp_path, capsys):
    clip = video(tmp_path / "small.mp4", 3, 64, 90)
    refused(capsys, "run", "--video", clip, "--fx", "40", "--fy", "40", "--cx", "32", "--cy", "40",
            "--out", tmp_path / "o", says=("64x90", "too narrow", "128 px"))


def test_a_still_image_named_like_a_video_is_not_a_trajectory(tmp_path, capsys):
    still = tmp_path / "still.mp4"
    cv2.imwrite(str(tmp_path / "still.png"), np.full((240, 600), 128, np.uint8))
    (tmp_path / "still.png").rename(still)
    code, _, err = cli(capsys, "run", "--video", still, "--fx", "300", "--fy", "300", "--cx", "300", "--cy", "100",
                       "--out", tmp_path / "o", "--method", "classical")
    assert code == 2 and "Traceback" not in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists() or not list((tmp_path / "o").iterdir())


@pytest.mark.parametrize("first", ["-5.0", "1e11"])
def test_mcap_unfit_stamps_are_refused_before_any_output(data, tmp_path, capsys, first):
    pytest.importorskip("rosbags")
    times = (data / "sequences" / "00" / "times.txt").read_text().splitlines()
    start = float(first)
    root = copy_with(data, tmp_path, "times.txt", "".join(f"{start + 0.1 * i:.6f}\n" for i in range(len(times))))
    refused(capsys, "run", "--data", root, "--sequence", "00", "--out", tmp_path / "o", "--method", "classical",
            "--mcap", says=("MCAP", "ROS time"))
    assert not (tmp_path / "o").exists() or not list((tmp_path / "o").iterdir())


def test_speed_prior_restarts_after_a_gap_instead_of_extrapolating():
    prior = SpeedPrior()
    for i in range(10):
        prior.update(0.1 * i, 11.5)
    hour_later = 0.9 + 3600.0
    assert prior.update(hour_later, None) is None  # no 41 km step: nothing is known of the gap
    assert prior.update(hour_later + 0.1, 10.0) == 10.0  # the history restarted at the gap
    short = SpeedPrior()
    for i in range(10):
        short.update(0.1 * i, 11.5)
    assert short.update(1.0, None) == pytest.approx(11.5)  # a normal frame interval keeps the prior


def test_eval_refuses_tiny_lengths_and_a_prediction_longer_than_the_ground_truth(data, tmp_path, capsys):
    gt = data / "poses" / "00.txt"
    refused(capsys, "eval", "--gt", gt, "--pred", gt, "--lengths", "1e-30", says="--lengths")
    long_pred = tmp_path / "long.txt"
    long_pred.write_text(gt.read_text() * 2)
    refused(capsys, "eval", "--gt", gt, "--pred", long_pred, says=("long.txt", "beyond the ground truth"))
    short_pred = tmp_path / "short.txt"
    short_pred.write_text("".join(gt.read_text().splitlines(keepends=True)[:5]))
    code, out, _ = cli(capsys, "eval", "--gt", gt, "--pred", short_pred)
    assert code == 0 and "5 of the ground truth's 8 predicted" in out


@pytest.mark.parametrize("opset", ["0", "7", "99"])
def test_export_opsets_outside_the_supported_range_are_refused(tmp_path, capsys, opset):
    refused(capsys, "export", "--format", "onnx", "--opset", opset, "--out", tmp_path / "m.onnx", says="--opset")
    assert list(tmp_path.iterdir()) == []


def test_export_format_follows_the_file_name_and_is_recorded(tmp_path, capsys):
    refused(capsys, "export", "--format", "torchscript", "--out", tmp_path / "m.onnx", says=".onnx")
    refused(capsys, "export", "--format", "onnx", "--out", tmp_path / "m.ts", says=".onnx")
    assert cli(capsys, "export", "--out", tmp_path / "m.ts")[0] == 0
    assert json.loads((tmp_path / "m.ts.json").read_text())["file_format"] == "torchscript"
    pytest.importorskip("onnx")
    assert cli(capsys, "export", "--out", tmp_path / "m.onnx")[0] == 0
    assert (tmp_path / "m.onnx").read_bytes()[:2] != b"PK"  # not a TorchScript zip under an ONNX name
    assert json.loads((tmp_path / "m.onnx.json").read_text())["file_format"] == "onnx"


@pytest.fixture(scope="module")
def a_run(data, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("report") / "run"
    from flowvo.cli import main

    assert main(["run", "--data", str(data), "--sequence", "00", "--out", str(out), "--method", "classical",
                 "--lengths", "1", "2", "-q"]) == 0
    return out


@pytest.mark.parametrize("frames", [0, 1, "abc", True, 2.5])
def test_report_refuses_a_run_json_with_bad_frames(a_run, tmp_path, capsys, frames):
    run = tmp_path / "run"
    subprocess.run(["cp", "-r", str(a_run), str(run)], check=True)
    summary = json.loads((run / "run.json").read_text())
    summary["frames"] = frames
    (run / "run.json").write_text(json.dumps(summary))
    refused(capsys, "report", run, "--out", tmp_path / "rep", says=("run.json", "frames"))


def test_report_escapes_the_runs_text_and_scores_their_own_lengths(a_run, tmp_path, capsys):
    run = tmp_path / "run"
    subprocess.run(["cp", "-r", str(a_run), str(run)], check=True)
    summary = json.loads((run / "run.json").read_text())
    summary["label"] = "x</script><script>alert(2)</script>"
    (run / "run.json").write_text(json.dumps(summary))
    assert cli(capsys, "report", run, "--out", tmp_path / "rep")[0] == 0
    page = (tmp_path / "rep" / "index.html").read_text()
    assert page.count("</script>") == 1 and page.count("<script") == 1
    embedded = page.split("id='results'>")[1].split("</script>")[0]
    assert json.loads(embedded)[0]["method"] == summary["label"]
    assert "1, 2 m sub-paths" in page  # the run's --lengths, not 100..800
    assert "t_err_vs_length_00.png" not in page and "n/a" not in page  # its 0.6 m path has no such sub-path
    summary["sequence"], summary["data"] = "<img src=x onerror=alert(1)>", None  # as a video run names it
    (run / "run.json").write_text(json.dumps(summary))
    refused(capsys, "report", run, "--out", tmp_path / "rep2", says=("run.json", "sequence"))
    assert not (tmp_path / "rep2").exists()


def test_report_of_a_video_run_has_its_path_figure_and_says_video(tmp_path, capsys):
    clip = video(tmp_path / "v.mp4", 4, 600, 240)
    assert cli(capsys, "run", "--video", clip, "--fx", "300", "--fy", "300", "--cx", "300", "--cy", "100",
               "--out", tmp_path / "r", "--method", "classical")[0] == 0
    assert cli(capsys, "report", tmp_path / "r", "--out", tmp_path / "rep")[0] == 0
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "v (video)" in page and "v (KITTI)" not in page
    assert (tmp_path / "rep" / "path_v.png").is_file()


def test_help_shows_defaults(capsys):
    code, out, _ = cli(capsys, "run", "--help")
    assert code == 0 and "(default: odom)" in out and "(default: height)" in out


def test_sigterm_during_a_pooled_synth_is_one_line_exit_143(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    process = subprocess.Popen([sys.executable, "-m", "flowvo.cli", "synth", "--out", str(tmp_path / "d"), "--frames",
                                "400", "--scale", "0.1", "--workers", "2", "-q"], stderr=subprocess.PIPE, text=True,
                               env=env)
    frames = tmp_path / "d" / "sequences" / "00" / "image_0"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(list(frames.glob("*.png"))) < 3 and process.poll() is None:
        time.sleep(0.02)
    process.send_signal(signal.SIGTERM)
    err = process.communicate(timeout=60)[1]
    assert process.returncode == 143 and err == "flowvo synth: terminated (resumable state kept)\n"


def test_ctrl_c_that_surfaces_as_another_error_is_still_one_line(capsys, monkeypatch, data, tmp_path):
    from flowvo.report import evaluation

    def import_cut_short(*args, **kwargs):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise RuntimeError("partially initialised module") from None

    monkeypatch.setattr(evaluation, "save_evaluation", import_cut_short)
    code, _, err = cli(capsys, "eval", "--gt", data / "poses" / "00.txt", "--pred", data / "poses" / "00.txt",
                       "--out", tmp_path / "e")
    assert code == 130 and err.startswith("flowvo eval: interrupted") and "resumable" not in err


def test_ground_truth_is_checked_before_the_drive_streams(data, tmp_path, capsys):
    root = tmp_path / "copy"
    subprocess.run(["cp", "-r", str(data), str(root)], check=True)
    (root / "poses" / "00.txt").write_text("not poses\n")
    before = tree_digest(root)
    refused(capsys, "run", "--data", root, "--sequence", "00", "--out", tmp_path / "o", "--method", "classical",
            says="00.txt:1")
    assert not (tmp_path / "o").exists() and tree_digest(root) == before
