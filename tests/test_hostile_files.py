"""Hostile files: damaged or foreign pose files, dataset files (frames, times, calibration, poses) and
run folders. Each ends in a correct result or one line naming the file and what is wrong."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from hostile import cli, refused

from flowvo.synth.dataset import synthesize

IDENTITY = "1 0 0 0 0 1 0 0 0 0 1 0"


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("files") / "data"
    synthesize(root, ["00"], seed=2, frames=12, scale=0.1, workers=1)
    return root


@pytest.fixture
def copy(data, tmp_path) -> Path:
    """A private copy of the dataset to damage."""
    return Path(shutil.copytree(data, tmp_path / "copy"))


def steps(n: int, start: int = 0, indexed: bool = False) -> str:
    """n poses 1 m apart along z, optionally frame-indexed from ``start``."""
    rows = [f"1 0 0 0 0 1 0 0 0 0 1 {i}.0" for i in range(n)]
    return "".join(f"{start + i} {row}\n" if indexed else f"{row}\n" for i, row in enumerate(rows))


POSE_FILES = {
    "binary": (b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe\x00binary", "not a text pose file"),
    "reflection": ("-1 0 0 0 0 1 0 0 0 0 1 0\n" + IDENTITY + "\n", ":1: rotation part has determinant -1"),
    "nan": (IDENTITY + "\n1 0 0 nan 0 1 0 0 0 0 1 0\n", ":2: pose contains NaN or infinity"),
    "overflow": (IDENTITY + "\n1 0 0 1e999 0 1 0 0 0 0 1 0\n", ":2: pose contains NaN or infinity"),
    "absurd translation": (IDENTITY + "\n1 0 0 1e300 0 1 0 0 0 0 1 0\n", ":2: translation beyond 1e+08 m"),
    "underscore": ("1 0 0 1_0 0 1 0 0 0 0 1 0\n", ":1: expected 12 numbers (or frame index + 12), found text"),
    "eleven numbers": ("1 0 0 0 0 1 0 0 0 0 1\n", ":1: expected 12 numbers (or frame index + 12), found 11"),
    "scaled rotation": ("2 0 0 0 0 2 0 0 0 0 2 0\n", ":1: rotation part is not orthonormal"),
    "mixed forms": (IDENTITY + "\n1 " + IDENTITY + "\n", ":2: mixes 12-number and frame-indexed"),
    "frame index huge": ("1e12 " + IDENTITY + "\n", ":1: frame index 1e12 is not an integer"),
    "frame index decreasing": ("5 " + IDENTITY + "\n3 " + IDENTITY + "\n", ":2: frame index 3 is not increasing"),
    "empty": ("\n\n", "pose file is empty"),
    "one pose": (IDENTITY + "\n", "shares 1 frame(s) with the ground truth"),
    "no shared frame": (steps(5, start=100, indexed=True), "shares 0 frame(s) with the ground truth"),
}


@pytest.mark.parametrize("name", POSE_FILES)
def test_eval_names_the_bad_prediction_file(tmp_path, capsys, name):
    content, message = POSE_FILES[name]
    pred = tmp_path / "pred.txt"
    pred.write_bytes(content if isinstance(content, bytes) else content.encode())
    (tmp_path / "gt.txt").write_text(steps(20))
    refused(capsys, "eval", "--gt", tmp_path / "gt.txt", "--pred", pred, "--out", tmp_path / "o",
            says=(str(pred), message))
    assert not (tmp_path / "o").exists()


def test_ground_truth_with_a_gap_is_refused(tmp_path, capsys):
    (tmp_path / "gt.txt").write_text(steps(1, 0, True) + steps(3, 2, True))
    refused(capsys, "eval", "--gt", tmp_path / "gt.txt", "--pred", tmp_path / "gt.txt",
            says=("gt.txt", "frame 1 is missing"))


@pytest.mark.parametrize("which", ["missing", "folder"])
def test_a_pose_path_that_is_no_file_is_named(tmp_path, capsys, which):
    path = tmp_path / "poses"
    if which == "folder":
        path.mkdir()
    refused(capsys, "eval", "--gt", path, "--pred", path, says=(str(path), "not found" if which == "missing"
                                                                 else "is not a file"))


def test_a_byte_order_mark_and_crlf_lines_are_read(tmp_path, capsys):
    (tmp_path / "gt.txt").write_bytes(b"\xef\xbb\xbf" + steps(20).replace("\n", "\r\n").encode())
    code, out, _ = cli(capsys, "eval", "--gt", tmp_path / "gt.txt", "--pred", tmp_path / "gt.txt")
    assert code == 0 and "ATE RMSE (align none)     0.000 m" in out


def test_metrics_json_is_strict_json_for_a_path_without_kitti_segments(tmp_path, capsys):
    gt = tmp_path / "gt.txt"
    gt.write_text(steps(3))
    assert cli(capsys, "eval", "--gt", gt, "--pred", gt, "--out", tmp_path / "o")[0] == 0

    def no_constants(name):
        raise AssertionError(f"{name} is not JSON")

    metrics = json.loads((tmp_path / "o" / "metrics.json").read_text(), parse_constant=no_constants)
    assert metrics["t_err_percent"] is None and metrics["rpe_rot_rmse_deg"] == 0.0


def run_args(data: Path, out: Path) -> list[object]:
    return ["run", "--data", data, "--sequence", "00", "--out", out, "--method", "classical"]


DATASET_DAMAGE = {
    "times not increasing": (lambda d: (d / "sequences/00/times.txt").write_text("0\n0.1\n0.1\n" + "1\n" * 9),
                             ("times.txt:3", "timestamps must increase")),
    "times nan": (lambda d: (d / "sequences/00/times.txt").write_text("nan\n" * 12),
                  ("times.txt:1", "not a finite number")),
    "times too few": (lambda d: (d / "sequences/00/times.txt").write_text("0\n"),
                      ("times.txt", "has 1 timestamps for 12 frames")),
    "times binary": (lambda d: (d / "sequences/00/times.txt").write_bytes(b"\xff\xfe\x00\x01" * 8),
                     ("times.txt:1", "expected one timestamp")),
    "frame not decodable": (lambda d: (d / "sequences/00/image_0/000004.png").write_bytes(
        (d / "sequences/00/image_0/000004.png").read_bytes()[:40]), ("000004.png", "cannot decode image")),
    "frame empty": (lambda d: (d / "sequences/00/image_0/000004.png").write_bytes(b""),
                    ("000004.png", "not a PNG image")),
    "frame missing": (lambda d: (d / "sequences/00/image_0/000004.png").unlink(),
                      ("image_0", "frame 000004.png is missing")),
    "calibration without P0": (lambda d: (d / "sequences/00/calib.txt").write_text("P1: " + "1 " * 12 + "\n"),
                               ("calib.txt", "missing P0")),
    "calibration binary": (lambda d: (d / "sequences/00/calib.txt").write_bytes(b"P0: \xff\xfe\x00" * 4),
                           ("calib.txt:1", "found text")),
    "calibration text": (lambda d: (d / "sequences/00/calib.txt").write_text("P0: one two\n"),
                         ("calib.txt:1", "found text")),
    "ground truth too short": (lambda d: (d / "poses/00.txt").write_text(steps(5)),
                               ("poses/00.txt", "has 5 poses for 12 frames")),
    "ground truth binary": (lambda d: (d / "poses/00.txt").write_bytes(bytes(range(256))),
                            ("poses/00.txt", "not a text pose file")),
    "one frame": (lambda d: [p.unlink() for p in sorted((d / "sequences/00/image_0").iterdir())[1:]]
                  and (d / "sequences/00/times.txt").write_text("0\n"), ("image_0", "has 1 frame(s)")),
}


@pytest.mark.parametrize("damage", DATASET_DAMAGE)
def test_run_names_the_damaged_dataset_file(copy, tmp_path, capsys, damage):
    spoil, message = DATASET_DAMAGE[damage]
    spoil(copy)
    refused(capsys, *run_args(copy, tmp_path / "out"), says=message)


@pytest.mark.parametrize("command", [["flow", "--cache", "{tmp}/c"], ["bench", "--methods", "classical"]])
def test_flow_and_bench_refuse_a_one_frame_sequence(copy, tmp_path, capsys, command):
    DATASET_DAMAGE["one frame"][0](copy)
    args = [command[0], "--data", copy, "--sequence", "00", *(a.format(tmp=tmp_path) for a in command[1:])]
    refused(capsys, *args, says="has 1 frame(s)")


@pytest.fixture(scope="module")
def run_folder(data, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("runs") / "run"
    from flowvo.cli import main

    assert main([str(a) for a in run_args(data, out)] + ["-q"]) == 0
    return out


RUN_FOLDER_DAMAGE = {
    "run.json not JSON": ("run.json", lambda s: s[: len(s) // 2], "run.json:"),
    "run.json not UTF-8": ("run.json", lambda s: "\udcff", "not UTF-8"),
    "run.json a list": ("run.json", lambda s: "[1, 2]", "lacks label"),
    "run.json without data": ("run.json", lambda s: json.dumps({k: v for k, v in json.loads(s).items()
                                                              if k != "data"}), "lacks data"),
    "run.json poses a path": ("run.json", lambda s: json.dumps({**json.loads(s), "poses": "../../etc/passwd"}),
                              "'poses' file name '../../etc/passwd' is a path"),
    "run.json sequence a number": ("run.json", lambda s: json.dumps({**json.loads(s), "sequence": 7}),
                                   "must be text"),
    "timing.json zero total": ("timing.json", lambda s: json.dumps({"seconds_per_frame": {
        "image_read": 0, "flow": 0, "network": 0, "total": 0}}), "total > 0"),
    "timing.json missing": ("timing.json", None, "no timing.json"),
}


@pytest.mark.parametrize("damage", RUN_FOLDER_DAMAGE)
def test_report_names_the_damaged_run_folder(run_folder, tmp_path, capsys, damage):
    name, spoil, message = RUN_FOLDER_DAMAGE[damage]
    folder = Path(shutil.copytree(run_folder, tmp_path / "run"))
    if spoil is None:
        (folder / name).unlink()
    else:
        (folder / name).write_bytes(spoil((folder / name).read_text()).encode("utf-8", "surrogateescape"))
    refused(capsys, "report", folder, "--out", tmp_path / "report", says=message)
    assert not (tmp_path / "report").exists()


def test_report_of_an_intact_run_folder_works(run_folder, tmp_path, capsys):
    assert cli(capsys, "report", run_folder, "--out", tmp_path / "report")[0] == 0
    assert np.loadtxt(run_folder / "00.txt").shape == (12, 12)
