"""``flowvo batch`` end to end on a small fleet: one output folder per drive as ``flowvo run`` writes it,
a broken drive fails alone, reruns keep complete drives and redo damaged ones, --retry-failed, settings
guard, the batch lock, bad input written nowhere, Ctrl-C."""

import json
import os
import shutil
import signal
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from batch_fleet import FRAMES, make_fleet, write_video
from hostile import interruptible

from flowvo.batch import run_batch
from flowvo.batch.done import read_drive_outputs
from flowvo.batch.lock import batch_lock
from flowvo.cli import main
from flowvo.errors import FlowvoError
from flowvo.io.outputs import run_outputs

SRC = Path(__file__).resolve().parents[1] / "src"
NAMES = ["kitti__00", "kitti__01", "videos__broken.mp4", "videos__good.avi"]


def batch_args(fleet, out, *extra):
    return ["-q", "batch", str(fleet.kitti), str(fleet.videos), "--calib", str(fleet.calib), "--out", str(out),
            "--workers", "2", *extra]


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    return make_fleet(tmp_path_factory.mktemp("fleet"))


@pytest.fixture(scope="module")
def first(fleet, tmp_path_factory):
    """The fleet's first batch (module-wide: tests that rerun it work on a copy)."""
    out = tmp_path_factory.mktemp("first") / "out"
    code = main(batch_args(fleet, out))
    return code, out


def rows(out: Path) -> dict:
    return {row["drive"]: row for row in json.loads((out / "summary.json").read_text())["drives"]}


def mtimes(out: Path) -> dict:
    return {name: (out / "drives" / name / "run.json").stat().st_mtime_ns for name in NAMES
            if (out / "drives" / name / "run.json").exists()}


def copy_of(out: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "out"
    shutil.copytree(out, copy)  # copy2: file times kept, so "not recomputed" stays checkable
    return copy


def test_a_broken_video_fails_alone_with_a_one_line_error_and_exit_code_1(first, capsys):
    code, out = first
    assert code == 1
    summary = rows(out)
    assert sorted(summary) == NAMES
    assert [summary[n]["status"] for n in NAMES] == ["ok", "ok", "failed", "ok"]
    error = summary["videos__broken.mp4"]["error"]
    assert "broken.mp4" in error and "OpenCV cannot open" in error and "\n" not in error
    assert all(summary[n]["frames"] == FRAMES and summary[n]["peak_memory_mib"] > 0 for n in NAMES if "broken" not in n)
    csv_lines = (out / "summary.csv").read_text().splitlines()
    assert len(csv_lines) == 5 and ",failed," in csv_lines[3] and "broken.mp4" in csv_lines[3]
    totals = json.loads((out / "summary.json").read_text())["batch"]
    assert (totals["ok"], totals["failed"], totals["frames"]) == (3, 1, 3 * FRAMES)


def test_each_drive_folder_holds_exactly_what_flowvo_run_writes(first):
    _, out = first
    assert sorted(p.name for p in (out / "drives" / "kitti__00").iterdir()) == sorted(run_outputs("00", steps=True))
    assert sorted(p.name for p in (out / "drives" / "videos__good.avi").iterdir()) == \
        sorted(set(run_outputs("good", steps=True)) - {"eval_good"})  # a video has no ground truth
    assert not (out / "drives" / "videos__broken.mp4").exists()  # refused before anything was written
    video_poses = np.loadtxt(out / "drives" / "videos__good.avi" / "good.txt")  # the same frames, losslessly
    np.testing.assert_allclose(video_poses, np.loadtxt(out / "drives" / "kitti__00" / "00.txt"), atol=1e-9)


def test_a_drive_whose_step_records_are_missing_is_not_complete(first, tmp_path):
    out = copy_of(first[1], tmp_path)
    folder = out / "drives" / "kitti__00"
    assert read_drive_outputs(folder).unscaled_steps == rows(first[1])["kitti__00"]["unscaled_steps"] == 0
    (folder / "00_steps.csv").unlink()
    with pytest.raises(FlowvoError, match="00_steps.csv named by run.json is missing"):
        read_drive_outputs(folder)


def test_the_page_lists_failed_drives_first_with_a_path_plot_per_completed_drive(first):
    _, out = first
    page = (out / "index.html").read_text()
    assert page.index("videos__broken.mp4") < page.index("kitti__00") < page.index("kitti__01")
    assert sorted(p.name for p in (out / "plots").iterdir()) == ["kitti__00.png", "kitti__01.png",
                                                                 "videos__good.avi.png"]
    assert page.count("<img ") == 3


def test_a_rerun_keeps_complete_drives_and_redoes_a_truncated_one(first, fleet, tmp_path):
    out = copy_of(first[1], tmp_path)
    before = mtimes(out)
    poses = out / "drives" / "kitti__01" / "01.txt"
    poses.write_text("".join(poses.read_text().splitlines(keepends=True)[:4]))  # a run cut short
    assert main(batch_args(fleet, out)) == 1  # the broken video still fails
    after = mtimes(out)
    assert after["kitti__00"] == before["kitti__00"] and after["videos__good.avi"] == before["videos__good.avi"]
    assert after["kitti__01"] != before["kitti__01"] and len(poses.read_text().splitlines()) == FRAMES
    summary, earlier = rows(out), rows(first[1])
    assert summary["kitti__00"]["reused"] and not summary["kitti__01"]["reused"]
    assert summary["kitti__00"]["peak_memory_mib"] == earlier["kitti__00"]["peak_memory_mib"]
    assert summary["videos__broken.mp4"]["status"] == "failed"


def test_retry_failed_runs_only_the_drives_that_failed(first, fleet, tmp_path):
    inputs = tmp_path / "inputs"  # the same layout (so the same drive names), with the broken video repaired
    shutil.copytree(fleet.kitti, inputs / "kitti")
    shutil.copytree(fleet.videos, inputs / "videos")
    write_video(inputs / "videos" / "broken.mp4", fleet.kitti, "01")
    out = copy_of(first[1], tmp_path)
    (out / "drives" / "kitti__01" / "run.json").unlink()  # incomplete, but it did not fail: not retried
    before = mtimes(out)
    code = main(["-q", "batch", str(inputs / "kitti"), str(inputs / "videos"), "--calib", str(fleet.calib),
                 "--out", str(out), "--retry-failed"])
    assert code == 0
    summary = rows(out)
    assert summary["videos__broken.mp4"]["status"] == "ok" and summary["videos__broken.mp4"]["frames"] == FRAMES
    assert summary["kitti__01"]["status"] == "pending"
    assert {k: v for k, v in mtimes(out).items() if k != "videos__broken.mp4"} == before


def test_results_made_with_other_settings_are_refused_unless_forced(first, fleet, tmp_path, capsys):
    out = copy_of(first[1], tmp_path)
    before = mtimes(out)
    capsys.readouterr()
    assert main(batch_args(fleet, out, "--method", "classical")) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "other settings" in err[0] and "method 'flowvo' -> 'classical'" in err[0]
    assert mtimes(out) == before
    assert main(batch_args(fleet, out, "--method", "classical", "--force")) == 1
    assert all(v != before[k] for k, v in mtimes(out).items())
    assert {row["method"] for row in rows(out).values() if row["status"] == "ok"} == {"classical"}


def test_a_second_batch_on_the_same_folder_is_refused_while_one_runs(first, fleet, tmp_path, capsys):
    out = copy_of(first[1], tmp_path)
    capsys.readouterr()
    with batch_lock(out):
        assert main(batch_args(fleet, out)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "another flowvo batch" in err[0]


@pytest.mark.parametrize("case", ["workers 0", "no input", "names collide", "unknown manifest column", "no drives"])
def test_bad_input_is_one_line_and_writes_nothing(case, fleet, tmp_path, capsys):
    out = tmp_path / "out"
    (tmp_path / "a b").mkdir()
    (tmp_path / "a_b").mkdir()
    (tmp_path / "a b" / "x.mp4").write_bytes(b"")
    (tmp_path / "a_b" / "x.mp4").write_bytes(b"")
    (tmp_path / "m.csv").write_text(f"path,colour\n{fleet.good_video},red\n")
    (tmp_path / "empty").mkdir()
    args = {"workers 0": [str(fleet.kitti), "--workers", "0"], "no input": [],
            "names collide": [str(tmp_path / "a b"), str(tmp_path / "a_b"), "--calib", str(fleet.calib)],
            "unknown manifest column": [str(tmp_path / "m.csv")], "no drives": [str(tmp_path / "empty")]}[case]
    try:
        code = main(["batch", *args, "--out", str(out)])
    except SystemExit as usage_error:  # argparse's own checks
        code = usage_error.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    expected = {"workers 0": "--workers: 0 is outside", "no input": "required: INPUT",
                "names collide": "would both be written to drives/a_b__x.mp4", "unknown manifest column": "'colour'",
                "no drives": "no drives found"}[case]
    assert expected in err[0]
    assert not out.exists()


def test_the_library_refuses_zero_workers_before_writing(fleet, tmp_path):
    from flowvo.batch import discover_drives

    with pytest.raises(FlowvoError, match="--workers must be at least 1"):
        run_batch(discover_drives([str(fleet.kitti)]), tmp_path / "out", workers=0)
    assert not (tmp_path / "out").exists()


def test_ctrl_c_exits_130_and_keeps_completed_drives_and_their_summary(fleet, tmp_path):
    long_video = tmp_path / "long" / "long.avi"
    long_video.parent.mkdir()
    write_video(long_video, fleet.kitti, "00", repeat=60)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": f"{SRC}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    process = interruptible([sys.executable, "-m", "flowvo.cli", "-q", "batch", str(fleet.kitti / "sequences/00"),
                             str(long_video), "--calib", str(fleet.calib), "--out", str(out), "--workers", "1"], env)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not list(out.glob("drives/*long.avi")) and process.poll() is None:
        time.sleep(0.02)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert err == "flowvo batch: interrupted (resumable state kept)\n"
    kitti, video = sorted(rows(out).values(), key=lambda row: row["kind"])
    assert (kitti["status"], video["status"]) == ("ok", "pending")
    assert len((out / kitti["output"] / "00.txt").read_text().splitlines()) == FRAMES
