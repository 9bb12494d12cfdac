"""Hostile input, round three (issue 52, and issue 49's real-world files): calibration files (damaged OpenCV
storage, byte-order marks, text for numbers, an image size other than the frames'), lens models that cannot
be undone, batch folders (someone else's files, an empty or file --out, resume against run.json, damaged
outputs, FIFOs, names from apart in the tree, drives without ground truth), the camera flags on a KITTI
drive, manifests naming their line and column, frame sizes and times, videos that end early, the classical
method on frames it cannot measure, and a second demo."""

import json
import os
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from batch_fleet import write_video
from hostile import cli, refused, tree_digest

from flowvo.batch import discover_drives
from flowvo.batch.done import read_drive_outputs
from flowvo.calibration.files import format_ros_calibration, read_camera_file
from flowvo.camera import CameraIntrinsics, LensDistortion, check_distortion
from flowvo.errors import FlowvoError
from flowvo.kitti.poses import read_kitti_poses
from flowvo.report.drive_summary import drive_summary
from flowvo.sources.video import jpeg_size_hw, next_timestamp_s, open_video_source
from flowvo.synth.dataset import synthesize

BOM = b"\xef\xbb\xbf"
KITTI = CameraIntrinsics(707.0912, 707.0912, 601.8873, 183.1104)


@pytest.fixture(scope="module")
def fleet(tmp_path_factory) -> dict[str, Path]:
    """A synthetic KITTI root (sequence 00, 10 frames of 310x94 px, with ground truth), the same frames as a
    lossless video, and the sequence's calib.txt."""
    folder = tmp_path_factory.mktemp("round3")
    kitti = folder / "kitti"
    synthesize(kitti, ["00"], seed=4, frames=10, scale=0.25, workers=1)
    videos = folder / "videos"
    videos.mkdir()
    return {"kitti": kitti, "video": write_video(videos / "good.avi", kitti),
            "calib": kitti / "sequences" / "00" / "calib.txt"}


@pytest.fixture(scope="module")
def done_batch(fleet, tmp_path_factory) -> Path:
    """A complete batch of the KITTI sequence (with ground truth) and the video (without), with MCAP files."""
    pytest.importorskip("mcap")
    out = tmp_path_factory.mktemp("done") / "out"
    from flowvo.cli import main

    assert main(["-q", "batch", str(fleet["kitti"]), str(fleet["video"]), "--calib", str(fleet["calib"]),
                 "--out", str(out), "--mcap", "--workers", "1"]) == 0
    return out


def frames_intrinsics(fleet) -> CameraIntrinsics:
    return CameraIntrinsics.from_matrix(np.array(
        [float(v) for v in fleet["calib"].read_text().split("\n")[0].split()[1:]]).reshape(3, 4))


def summary_rows(out: Path) -> dict:
    return {row["drive"]: row for row in json.loads((out / "summary.json").read_text())["drives"]}


# --- batch output folders ---------------------------------------------------------------------------------------

def test_batch_refuses_a_folder_holding_someone_elses_index_and_summary(fleet, tmp_path, capsys):
    site = tmp_path / "site"
    site.mkdir()
    (site / "index.html").write_text("mine\n")
    (site / "summary.csv").write_text("my,data\n")
    before = tree_digest(site)
    refused(capsys, "batch", fleet["video"], "--calib", fleet["calib"], "--out", site,
            says=("summary.csv, index.html", "no flowvo batch wrote", "--force"))
    assert tree_digest(site) == before


def test_batch_refuses_an_empty_out_instead_of_writing_into_the_current_folder(fleet, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "index.html").write_text("mine\n")
    before = tree_digest(tmp_path)
    refused(capsys, "batch", fleet["video"], "--calib", fleet["calib"], "--out", "", says="--out is empty")
    assert tree_digest(tmp_path) == before


def test_batch_refuses_an_out_that_is_a_file(fleet, tmp_path, capsys):
    (tmp_path / "bo").write_text("x\n")
    refused(capsys, "batch", fleet["video"], "--calib", fleet["calib"], "--out", tmp_path / "bo",
            says=("bo", "--out is a file"))
    assert (tmp_path / "bo").read_text() == "x\n"


def test_batch_refuses_a_distortion_of_the_wrong_length_for_a_kitti_drive_before_writing(fleet, tmp_path, capsys):
    refused(capsys, "batch", fleet["kitti"], "--dist", "0.1", "0", "0", "--out", tmp_path / "bo",
            says=("--dist", "4 or 5 coefficients, got 3"))
    assert not (tmp_path / "bo").exists()


# --- batch resume ------------------------------------------------------------------------------------------------

def test_a_kept_result_of_another_method_is_refused_from_its_run_json_without_the_summary(fleet, tmp_path, capsys):
    out = tmp_path / "bo"
    assert cli(capsys, "batch", fleet["kitti"], "--method", "classical", "--out", out, "--workers", "1")[0] == 0
    (out / "summary.json").unlink()
    before = tree_digest(out / "drives")
    refused(capsys, "batch", fleet["kitti"], "--out", out, "--workers", "1",
            says=("method 'classical' -> 'flowvo' (its run.json)", "--force"))
    assert tree_digest(out / "drives") == before


@pytest.mark.parametrize("damage", ["mcap cut in half", "metrics.json garbage", "steps emptied"])
def test_a_drive_whose_mcap_metrics_or_steps_do_not_parse_is_not_complete(done_batch, tmp_path, damage):
    folder = tmp_path / "00"
    shutil.copytree(done_batch / "drives" / "kitti__00", folder)
    read_drive_outputs(folder)  # complete as written
    if damage == "mcap cut in half":
        data = (folder / "00.mcap").read_bytes()
        (folder / "00.mcap").write_bytes(data[: len(data) // 2])
    elif damage == "metrics.json garbage":
        (folder / "eval_00" / "metrics.json").write_text("garbage{")
    else:
        (folder / "00_steps.csv").write_text("")
    name = {"mcap cut in half": "00.mcap", "metrics.json garbage": "metrics.json", "steps emptied": "00_steps.csv"}
    with pytest.raises(FlowvoError, match=name[damage]):
        read_drive_outputs(folder)


def test_the_rerun_of_a_batch_redoes_a_drive_whose_mcap_was_cut(done_batch, fleet, tmp_path, capsys):
    out = tmp_path / "out"
    shutil.copytree(done_batch, out)
    mcap = out / "drives" / "kitti__00" / "00.mcap"
    mcap.write_bytes(mcap.read_bytes()[:100])
    assert cli(capsys, "batch", fleet["kitti"], fleet["video"], "--calib", fleet["calib"], "--out", out, "--mcap",
               "--workers", "1")[0] == 0
    rows = summary_rows(out)
    assert not rows["kitti__00"]["reused"] and rows["videos__good.avi"]["reused"]
    read_drive_outputs(out / "drives" / "kitti__00")


# --- runs without ground truth in the batch summary and index ------------------------------------------------

def test_the_batch_summary_gives_distance_duration_speeds_and_heading_of_every_drive(done_batch):
    rows = summary_rows(done_batch)
    for name, stem in (("kitti__00", "00"), ("videos__good.avi", "good")):
        folder = done_batch / "drives" / name
        times_s = np.loadtxt(folder / f"{stem}.tum")[:, 0]
        expected = drive_summary(read_kitti_poses(folder / f"{stem}.txt").T_world_cam, times_s)
        row = rows[name]
        assert row["path_length_m"] == pytest.approx(expected["distance_m"], abs=1e-3) and row["path_length_m"] > 1
        assert row["duration_s"] == pytest.approx(expected["duration_s"], abs=1e-3)
        assert row["mean_speed_mps"] == pytest.approx(expected["mean_speed_mps"], abs=1e-3)
        assert row["top_speed_mps"] == pytest.approx(expected["top_speed_mps"], abs=1e-3)
        assert row["heading_change_deg"] == pytest.approx(expected["heading_change_deg"], abs=0.01)
    assert rows["videos__good.avi"]["t_err_percent"] is None  # the video has no ground truth
    header = (done_batch / "summary.csv").read_text().splitlines()[0].split(",")
    assert {"mean_speed_mps", "top_speed_mps", "heading_change_deg", "warnings"} <= set(header)


def test_the_index_page_is_a_fixed_width_and_shows_what_each_drive_drove(done_batch, tmp_path):
    from flowvo.batch.index_page import PAGE_WIDTH_PX, write_index
    from flowvo.batch.record import DriveSummary

    page = (done_batch / "index.html").read_text()
    assert f"max-width:{PAGE_WIDTH_PX}px" in page and "table-layout:fixed" in page and PAGE_WIDTH_PX <= 1280
    row = summary_rows(done_batch)["videos__good.avi"]
    assert f"{row['path_length_m']:.1f} m in {row['duration_s']:.1f} s" in page
    assert f"top {row['top_speed_mps']:.1f} m/s" in page and f"heading {row['heading_change_deg']:+.1f} deg" in page
    assert "KITTI metric" not in page and "t_err" not in page  # no drive long enough for it: no empty column
    scored = DriveSummary.from_dict({**summary_rows(done_batch)["kitti__00"], "t_err_percent": 1.234})
    page = write_index(tmp_path, [DriveSummary.from_dict(row), scored], {"ok": 2}).read_text()
    assert "KITTI metric" in page and "t_err 1.23 %" in page


# --- camera flags and manifests -----------------------------------------------------------------------------------

def test_the_four_intrinsics_flags_override_a_kitti_drives_calib_txt_in_batch(fleet, tmp_path, capsys):
    out = tmp_path / "bo"
    assert cli(capsys, "batch", fleet["kitti"], "--fx", "80", "--fy", "80", "--cx", "150", "--cy", "46",
               "--out", out, "--workers", "1")[0] == 0
    camera = json.loads((out / "drives" / "00" / "run.json").read_text())["camera"]
    assert (camera["source"], camera["fx"], camera["cx"]) == ("flags", 80.0, 150.0)


def test_manifest_camera_errors_name_the_manifest_line_and_column_not_a_flag(fleet, tmp_path, capsys):
    manifest = tmp_path / "fleet.csv"
    manifest.write_text(f"path,camera_height_m\n{fleet['video']},1.5\n{fleet['video']},100\n")
    err = refused(capsys, "batch", manifest, "--out", tmp_path / "bo",
                  says=(f"{manifest}:3: camera_height_m:", "got 100.0"))
    assert "--camera-height" not in err
    manifest.write_text(f"path,fx,fy\n{fleet['video']},80,80\n")
    refused(capsys, "batch", manifest, "--out", tmp_path / "bo", says=(f"{manifest}:2: fx, fy:", "missing cx, cy"))
    assert not (tmp_path / "bo").exists()


# --- calibration files ---------------------------------------------------------------------------------------------

OPENCV_HEAD = "%YAML:1.0\n---\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"


@pytest.mark.parametrize("text, says", [
    (OPENCV_HEAD + "   data: [ 707.1, 0., 601.9, 0., 707.1, 183.1 ]\n",
     "camera_matrix says rows 3, cols 3 (9 numbers) but its data holds 6"),
    (OPENCV_HEAD + "   data: [ 707.1, 0., 601.9, 0., 707.",
     "cam.yaml:7: not a readable OpenCV FileStorage file"),
    (OPENCV_HEAD + "   data: [ 707.1, 0., 601.9, 0., 707.1, 183.1, 0., 0., 1. ]\ncamera_height_m: \"tall\"\n",
     "camera_height_m must be a number, got 'tall'"),
    (OPENCV_HEAD + "   data: [ 707.1, 0., 601.9, 0., 707.1, 183.1, 0., 0., 1. ]\nimage_width: 640\n",
     "gives the image width but not its height"),
])
def test_damaged_opencv_calibrations_are_one_line_naming_the_file(tmp_path, capsys, text, says):
    (tmp_path / "cam.yaml").write_text(text)
    refused(capsys, "run", "--video", "unused.mp4", "--calib", tmp_path / "cam.yaml", "--out", tmp_path / "o",
            says=("cam.yaml", says))
    assert not (tmp_path / "o").exists()


def test_byte_order_marks_are_no_part_of_calibration_and_time_files(fleet, tmp_path):
    storage = cv2.FileStorage(str(tmp_path / "cam.xml"), cv2.FILE_STORAGE_WRITE)
    storage.write("camera_matrix", KITTI.K)
    storage.release()
    (tmp_path / "calib.txt").write_text("P0: 707.0912 0 601.8873 0 0 707.0912 183.1104 0 0 0 1 0\n")
    for name in ("cam.xml", "calib.txt"):
        (tmp_path / name).write_bytes(BOM + (tmp_path / name).read_bytes())
        assert read_camera_file(tmp_path / name).intrinsics == KITTI
    root = tmp_path / "kitti"
    shutil.copytree(fleet["kitti"], root)
    sequence = root / "sequences" / "00"
    for name in ("calib.txt", "times.txt"):
        (sequence / name).write_bytes(BOM + (sequence / name).read_bytes())
    from flowvo.kitti.sequence import KittiSequence

    read = KittiSequence(root, "00")
    np.testing.assert_array_equal(read.times_s, KittiSequence(fleet["kitti"], "00").times_s)
    assert read.calibration.K0[0, 0] > 0


@pytest.mark.parametrize("kind", ["opencv", "ros", "kalibr"])
def test_a_calibration_made_at_another_aspect_ratio_is_refused_naming_both_sizes(fleet, tmp_path, capsys, kind):
    path = tmp_path / "cam.yaml"
    K = frames_intrinsics(fleet)
    if kind == "opencv":
        path.write_text(OPENCV_HEAD + f"   data: [ {K.fx}, 0., {K.cx}, 0., {K.fy}, {K.cy}, 0., 0., 1. ]\n"
                                      "image_width: 640\nimage_height: 480\n")
    elif kind == "ros":
        path.write_text(format_ros_calibration(K, LensDistortion(), (480, 640)))
    else:
        path.write_text(f"cam0:\n  camera_model: pinhole\n  intrinsics: [{K.fx}, {K.fy}, {K.cx}, {K.cy}]\n"
                        "  distortion_model: none\n  distortion_coeffs: []\n  resolution: [640, 480]\n")
    refused(capsys, "run", "--video", fleet["video"], "--calib", path, "--out", tmp_path / "o",
            says=("cam.yaml", "calibrated on 640x480 images, the frames are 310x94"))
    assert not (tmp_path / "o").exists()


def test_a_calibration_made_at_twice_the_frames_size_is_scaled_to_them_and_said(fleet, tmp_path, capsys):
    K = frames_intrinsics(fleet)
    (tmp_path / "double.yaml").write_text(format_ros_calibration(K.scaled(2.0, 2.0), LensDistortion(), (188, 620)))
    code, out, _ = cli(capsys, "run", "--video", fleet["video"], "--calib", tmp_path / "double.yaml",
                       "--out", tmp_path / "scaled")
    assert code == 0 and "scaled to the frames from the calibration's 620x188 images" in out
    camera = json.loads((tmp_path / "scaled" / "run.json").read_text())["camera"]
    assert camera["scaled_from_image_size"] == [620, 188]
    assert [camera[k] for k in ("fx", "fy", "cx", "cy")] == pytest.approx([K.fx, K.fy, K.cx, K.cy], abs=1e-9)
    assert cli(capsys, "run", "--video", fleet["video"], "--calib", fleet["calib"], "--out", tmp_path / "own")[0] == 0
    np.testing.assert_allclose(np.loadtxt(tmp_path / "scaled" / "good.txt"), np.loadtxt(tmp_path / "own" / "good.txt"),
                               atol=1e-6)


# --- lens models ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("k1, says", [("1e6", "stretches the image"), ("80", "stretches the image"),
                                      ("-5", "cannot be undone")])
def test_a_lens_model_that_cannot_be_undone_over_the_frames_is_refused_before_writing(fleet, tmp_path, capsys,
                                                                                       k1, says):
    refused(capsys, "run", "--video", fleet["video"], "--calib", fleet["calib"], "--dist", k1, "0", "0", "0",
            "--out", tmp_path / "o", says=("--dist", says, "310x94"))
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("intrinsics, size_hw, distortion", [
    (KITTI, (370, 1226), LensDistortion("plumb_bob", (-0.25, 0.05, 0.0, 0.0))),  # docs/camera.md's warped clips
    (CameraIntrinsics(1156.5, 1151.3, 671.3, 389.2), (720, 1280),
     LensDistortion("plumb_bob", (-0.247, -0.025, 0.0, 0.0))),  # the dash-cam's own (its README)
    (CameraIntrinsics(310.0, 310.0, 309.5, 93.5), (188, 620), LensDistortion("plumb_bob", (-0.25, 0.05, 0, 0))),
    (CameraIntrinsics(300.0, 300.0, 320.0, 240.0), (480, 640), LensDistortion("equidistant", (0.1, 0.01, 0, 0))),
])
def test_real_and_synthetic_lenses_pass_the_lens_check(intrinsics, size_hw, distortion):
    check_distortion(intrinsics, distortion, size_hw, "lens")


# --- frames and times ---------------------------------------------------------------------------------------------

def test_a_motion_jpeg_whose_frame_size_changes_is_refused_not_resampled(tmp_path, capsys):
    rng = np.random.default_rng(0)
    path = tmp_path / "mixed.mjpeg"
    with open(path, "wb") as handle:
        for width in (160, 160, 160, 320, 320):
            handle.write(cv2.imencode(".jpg", rng.integers(0, 255, (90, width), dtype=np.uint8))[1].tobytes())
    source = open_video_source(path)
    assert source.image_size_hw == (90, 160)
    with pytest.raises(FlowvoError, match="frame 3 is 320x90, the first is 160x90"):
        list(source.frames())
    assert jpeg_size_hw(b"not a jpeg") is None


def test_times_closer_than_a_ten_thousandth_of_a_second_are_refused_with_their_line(fleet, tmp_path, capsys):
    root = tmp_path / "kitti"
    shutil.copytree(fleet["kitti"], root)
    times = root / "sequences" / "00" / "times.txt"
    times.write_text("".join(f"{i * 1e-12:.15e}\n" for i in range(10)))
    refused(capsys, "run", "--data", root, "--sequence", "00", "--out", tmp_path / "o",
            says=("times.txt:2", "at least 0.0001 s apart"))
    assert next_timestamp_s(1000.00001, 1.0, 25.0) == pytest.approx(1.04)  # a video's: timed by its frame rate
    assert next_timestamp_s(1000.00001, 1.0, 1e6) is None  # unless that rate is beyond any camera


def test_a_video_that_ends_before_its_stated_frame_count_runs_to_its_last_frame_and_resumes(fleet, tmp_path, capsys):
    video = tmp_path / "in" / "cut.avi"
    video.parent.mkdir()
    data = fleet["video"].read_bytes()
    video.write_bytes(data[: int(len(data) * 0.7)])
    source = open_video_source(video)
    decoded = len(list(source.frames()))
    assert 2 <= decoded < source.frame_count == 10 and "decoding stopped" in source.warnings[0]
    out = tmp_path / "bo"
    code, printed, _ = cli(capsys, "batch", video.parent, "--calib", fleet["calib"], "--out", out, "--workers", "1")
    assert code == 0 and "warning: cut.avi:" in printed and "decoding stopped" in printed
    run = json.loads((out / "drives" / "cut.avi" / "run.json").read_text())
    assert run["frames"] == decoded and "last good frame" in run["warnings"][0]
    assert cli(capsys, "batch", video.parent, "--calib", fleet["calib"], "--out", out, "--workers", "1")[0] == 0
    assert summary_rows(out)["cut.avi"]["reused"]


def test_the_classical_method_says_when_it_measured_nothing(tmp_path, capsys):
    path = tmp_path / "tiny.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), 10.0, (40, 30))
    texture = np.random.default_rng(1).integers(0, 255, (30, 60), dtype=np.uint8)
    for i in range(6):
        writer.write(cv2.cvtColor(np.ascontiguousarray(texture[:, 2 * i:2 * i + 40]), cv2.COLOR_GRAY2BGR))
    writer.release()
    code, _, _ = cli(capsys, "run", "--video", path, "--method", "classical", "--fx", "30", "--fy", "30", "--cx", "20",
                     "--cy", "15", "--out", tmp_path / "o")
    run = json.loads((tmp_path / "o" / "run.json").read_text())
    assert code == 0 and run["classical_steps"]["fitted"] == 0
    assert "fitted the motion of none of the 5 steps" in run["warnings"][0] and "40x30" in run["warnings"][0]


# --- inputs of a batch ---------------------------------------------------------------------------------------------

@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_in_an_input_folder_is_skipped_and_one_named_is_refused(fleet, tmp_path, capsys):
    folder = tmp_path / "in"
    folder.mkdir()
    shutil.copy(fleet["video"], folder / "good.avi")
    os.mkfifo(folder / "fifo.mp4")
    assert [drive.name for drive in discover_drives([str(folder)])] == ["good.avi"]
    refused(capsys, "batch", folder / "fifo.mp4", "--out", tmp_path / "bo", says=("fifo.mp4", "neither a file"))
    refused(capsys, "run", "--video", folder / "fifo.mp4", "--out", tmp_path / "o", says="not a regular file")


def test_inputs_from_apart_in_the_tree_are_named_from_their_own_folders(fleet, tmp_path):
    deep = tmp_path / "home" / "me" / "data" / "real"
    shutil.copytree(fleet["kitti"], deep / "kitti_clips")
    (tmp_path / "tmp" / "videos").mkdir(parents=True)
    shutil.copy(fleet["video"], tmp_path / "tmp" / "videos" / "cam.mp4")
    names = [d.name for d in discover_drives([str(deep / "kitti_clips"), str(tmp_path / "tmp" / "videos")])]
    assert names == ["kitti_clips__00", "videos__cam.mp4"]
    side_by_side = [d.name for d in discover_drives([str(fleet["kitti"]), str(fleet["video"])])]
    assert side_by_side == ["kitti__00", "videos__good.avi"]  # named as before: from their common folder


# --- demo -----------------------------------------------------------------------------------------------------------

def test_a_second_demo_reuses_the_first_ones_runs(fleet, tmp_path, capsys):
    out = tmp_path / "demo"
    args = ["demo", "--data", fleet["kitti"], "--sequence", "00", "--out", out]
    assert cli(capsys, *args)[0] == 0
    stamps = {p: p.stat().st_mtime_ns for p in out.glob("*/run.json")}
    code, printed, _ = cli(capsys, *args)
    assert code == 0 and "report:" in printed
    assert {p: p.stat().st_mtime_ns for p in out.glob("*/run.json")} == stamps and len(stamps) == 4
    refused(capsys, *args, "--camera-height", "1.3", says=("holds an earlier result", "--force"))
