"""The public Python API (docs/api.md): frames pushed one at a time give exactly the poses of ``flowvo run``, for
every method; bad frames, times and calls are one clear FlowvoError; runs made from Python save what ``flowvo
run`` writes (the report and the batch index read them); the doc's examples run."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

import flowvo
from flowvo.cli import main
from flowvo.errors import FlowvoError
from flowvo.kitti.poses import format_kitti_poses
from flowvo.methods import METHODS
from flowvo.trajectory import Trajectory as PoseTable

ROOT = Path(__file__).resolve().parents[1]




@pytest.fixture(scope="session")
def clip(clip_06: Path) -> Path:
    """Real clip 06 (conftest)."""
    return clip_06


def clip_frames(clip: Path, count: int | None = None, flags: int = cv2.IMREAD_GRAYSCALE
                ) -> list[tuple[float, np.ndarray]]:
    times_s = np.loadtxt(clip / "times.txt")[:count]
    return [(float(t), cv2.imread(str(clip / "image_0" / f"{i:06d}.png"), flags)) for i, t in enumerate(times_s)]


def kitti_text(poses) -> str:
    return format_kitti_poses(PoseTable.from_poses(np.stack([pose.T_world_cam for pose in poses])))


def pushed(camera, frames, method: str = "flowvo", **options) -> list:
    vo = flowvo.Odometry(camera, method, **options)
    poses = []
    for time_s, image in frames:
        poses += vo.push(image, time_s)
    return poses + vo.close()


def cli_poses(clip: Path, out: Path, *args: str) -> str:
    assert main(["-q", "run", "--data", str(clip.parents[1]), "--sequence", clip.name, "--out", str(out),
                 *args]) == 0
    return (out / f"{clip.name}.txt").read_text()


@pytest.mark.slow
@pytest.mark.parametrize("method", list(METHODS))
def test_pushed_frames_give_the_kitti_file_of_flowvo_run_to_the_last_digit(clip, tmp_path, method):
    if method == "flowvo-ba":
        pytest.importorskip("gtsam", reason="flowvo-ba needs the ba extra (gtsam)")
    expected = cli_poses(clip, tmp_path / "cli", "--method", method)
    poses = pushed(flowvo.Camera.from_file(clip / "calib.txt"), clip_frames(clip), method)
    assert kitti_text(poses) == expected
    assert [pose.frame for pose in poses] == list(range(50))
    assert [pose.time_s for pose in poses] == [t for t, _ in clip_frames(clip, 50)]


def test_poses_carry_their_step_length_sigma_and_what_measured_it_as_the_steps_csv(clip, tmp_path):
    cli_poses(clip, tmp_path / "cli", "--max-frames", "20")
    rows = [line.split(",") for line in (tmp_path / "cli" / "06_steps.csv").read_text().splitlines()[1:]]
    vo = flowvo.Odometry(flowvo.Camera.from_file(clip / "calib.txt"))
    returned = [len(vo.push(image, time_s)) for time_s, image in clip_frames(clip, 20)]
    assert vo.latency_frames == 5 and returned == [1] + [0] * 5 + [1] * 14  # frame 0's at once, each step's 5
    # frames after its frame
    poses = vo.poses + vo.close()
    assert poses[0].length_m == 0 and poses[0].measured_by is None
    assert [f"{pose.length_m:.6f}" for pose in poses[1:]] == [row[2] for row in rows]
    assert [f"{pose.length_log_sigma:.6f}" for pose in poses[1:]] == [row[3] for row in rows]
    assert [pose.measured_by for pose in poses[1:]] == [row[4] for row in rows]
    np.testing.assert_array_equal(poses[7].T_world_cam, poses[6].T_world_cam @ poses[7].T_prev_cur)


def test_whole_drive_from_a_folder_and_from_an_iterable_equal_flowvo_run(clip, tmp_path):
    expected = cli_poses(clip, tmp_path / "cli", "--max-frames", "25")
    from_folder = flowvo.run(clip, max_frames=25)
    assert kitti_text(from_folder) == expected and from_folder.ground_truth is not None
    colour = clip_frames(clip, 25, cv2.IMREAD_COLOR)  # BGR frames: converted as the video source converts them
    from_iterable = flowvo.run(iter(colour), camera=flowvo.Camera.from_file(clip / "calib.txt"), name="mine")
    assert kitti_text(from_iterable) == expected and from_iterable.name == "mine"
    np.testing.assert_array_equal(from_iterable.times_s, [t for t, _ in colour])


def test_colour_and_16_bit_frames_give_the_poses_of_their_grey_frames(clip):
    camera = flowvo.Camera.from_file(clip / "calib.txt")
    grey = clip_frames(clip, 8)
    expected = kitti_text(pushed(camera, grey, "classical"))
    rgb = [(t, np.repeat(image[:, :, None], 3, axis=2)) for t, image in grey]
    assert kitti_text(pushed(camera, rgb, "classical", channel_order="rgb")) == expected
    sixteen = [(t, image.astype(np.uint16) << 8 | 0x7F) for t, image in grey]
    assert kitti_text(pushed(camera, sixteen, "classical")) == expected


@pytest.fixture
def started(clip):
    vo = flowvo.Odometry(flowvo.Camera.from_file(clip / "calib.txt"), "classical")
    frames = clip_frames(clip, 3)
    vo.push(frames[0][1], frames[0][0])
    return vo, frames


def test_push_after_close_is_one_clear_error(started):
    vo, frames = started
    vo.close()
    assert vo.close() == []
    with pytest.raises(FlowvoError, match="push after close"):
        vo.push(frames[1][1], frames[1][0])


def test_a_frame_of_another_size_is_refused_and_changes_nothing(started):
    vo, frames = started
    with pytest.raises(FlowvoError, match=r"frame 1 is 620x188 px, the drive's first frame 1226x370"):
        vo.push(cv2.resize(frames[1][1], (620, 188)), frames[1][0])
    assert len(vo.push(frames[1][1], frames[1][0])) == 1 and vo.frames == 2


@pytest.mark.parametrize("time_s", [0.0, -1.0, float("nan"), float("inf")])
def test_a_time_that_does_not_increase_is_refused(started, time_s):
    vo, frames = started
    with pytest.raises(FlowvoError, match="timestamps must increase|must be finite"):
        vo.push(frames[1][1], time_s)


@pytest.mark.parametrize(("image", "message"), [
    (np.zeros((370, 1226), np.float32), "pixels of type float32 are not taken"),
    (np.zeros((370, 1226, 2), np.uint8), "is not a frame"),
    ([[0, 1], [2, 3]], "expected a NumPy array"),
])
def test_frames_of_types_no_source_gives_are_refused(started, image, message):
    vo, frames = started
    with pytest.raises(FlowvoError, match=message):
        vo.push(image, frames[1][0])


def test_bad_camera_and_method_are_refused_before_any_frame():
    with pytest.raises(FlowvoError, match="unknown method 'orb'"):
        flowvo.Odometry(flowvo.Camera(700, 700, 600, 180), "orb")
    with pytest.raises(FlowvoError, match="focal lengths"):
        flowvo.Camera(0.1, 700, 600, 180)
    with pytest.raises(FlowvoError, match="camera must be a flowvo.Camera"):
        flowvo.Odometry((700, 700, 600, 180))
    with pytest.raises(FlowvoError, match="camera height"):
        flowvo.Camera(700, 700, 600, 180, height_m=-1)


def test_a_principal_point_outside_the_frames_is_refused_at_the_first_frame(clip):
    vo = flowvo.Odometry(flowvo.Camera(700, 700, 2000, 180), "classical")
    time_s, image = clip_frames(clip, 1)[0]
    with pytest.raises(FlowvoError, match="outside the 1226x370 image"):
        vo.push(image, time_s)
    with pytest.raises(FlowvoError, match="earlier frame failed"):
        vo.push(image, time_s + 0.1)


CALIBRATIONS = {
    "opencv.yaml": "%YAML:1.0\n---\nimage_width: 1226\nimage_height: 370\ncamera_matrix: !!opencv-matrix\n  rows: 3\n"
                   "  cols: 3\n  dt: d\n  data: [707.0912, 0., 601.8873, 0., 707.0912, 183.1104, 0., 0., 1.]\n"
                   "distortion_coefficients: !!opencv-matrix\n  rows: 1\n  cols: 5\n  dt: d\n"
                   "  data: [-0.1, 0.01, 0., 0., 0.]\n",
    "ros.yaml": "image_width: 1226\nimage_height: 370\ncamera_name: cam\ncamera_matrix:\n  rows: 3\n  cols: 3\n"
                "  data: [707.0912, 0, 601.8873, 0, 707.0912, 183.1104, 0, 0, 1]\ndistortion_model: plumb_bob\n"
                "distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [-0.1, 0.01, 0, 0, 0]\ncamera_height_m: 1.7\n",
    "camchain.yaml": "cam0:\n  camera_model: pinhole\n  intrinsics: [707.0912, 707.0912, 601.8873, 183.1104]\n"
                     "  distortion_model: radtan\n  distortion_coeffs: [-0.1, 0.01, 0, 0]\n  resolution: [1226, 370]\n",
}


@pytest.mark.parametrize("name", list(CALIBRATIONS))
def test_camera_from_every_calibration_format(tmp_path, name):
    (tmp_path / name).write_text(CALIBRATIONS[name])
    camera = flowvo.Camera.from_file(tmp_path / name, pitch_deg=2.0, roll_deg=-3.0)
    assert (camera.fx, camera.fy, camera.cx, camera.cy) == (707.0912, 707.0912, 601.8873, 183.1104)
    assert camera.distortion.model == "plumb_bob" and camera.distortion.coefficients[:2] == (-0.1, 0.01)
    assert (camera.pitch_deg, camera.roll_deg) == (2.0, -3.0)
    assert camera.height_m == (1.7 if name == "ros.yaml" else None)
    options = camera.run_options()  # a run reads it as --calib does, with --camera-pitch and --camera-roll
    assert (options["calib"], options["camera_pitch_deg"], options["camera_roll_deg"]) == \
        (str(tmp_path / name), 2.0, -3.0)


def test_camera_from_a_kitti_calib_and_from_numbers_run_alike(clip):
    from_file = flowvo.Camera.from_file(clip / "calib.txt")
    assert (from_file.fx, from_file.cx, from_file.cy) == (707.0912, 601.8873, 183.1104)
    numbers = flowvo.Camera(707.0912, 707.0912, 601.8873, 183.1104)
    frames = clip_frames(clip, 6)
    assert kitti_text(pushed(numbers, frames, "classical")) == kitti_text(pushed(from_file, frames, "classical"))


def test_evaluate_gives_the_numbers_of_flowvo_run(clip, tmp_path):
    cli_poses(clip, tmp_path / "cli", "--method", "classical", "--lengths", "10", "20")
    metrics = json.loads((tmp_path / "cli" / "eval_06" / "metrics.json").read_text())
    from_file = flowvo.evaluate(clip.parents[1] / "poses" / "06.txt", tmp_path / "cli" / "06.txt", lengths=(20, 10))
    assert from_file.t_err_percent == pytest.approx(metrics["t_err_percent"], rel=1e-9)  # the file holds 10 digits
    assert from_file.ate_rmse_m == pytest.approx(metrics["ate_rmse_m"], rel=1e-9)
    scores = flowvo.run(clip, method="classical").evaluate(lengths=(10, 20))
    assert {key: scores.metrics[key] for key in metrics} == metrics
    with pytest.raises(FlowvoError, match=r"expected a pose file, a trajectory or finite poses"):
        flowvo.evaluate(np.zeros((5, 2)), tmp_path / "cli" / "06.txt")


def test_runs_made_from_python_read_in_the_report_and_the_batch_index(clip, tmp_path):
    from flowvo.batch.done import read_drive_outputs
    from flowvo.batch.index_page import write_index
    from flowvo.batch.record import summarize
    from flowvo.batch.spec import Drive
    from flowvo.report.page import load_run, write_report

    whole = flowvo.run(clip, max_frames=20)
    summary = whole.save(tmp_path / "whole", lengths=(10,))
    vo = flowvo.Odometry(flowvo.Camera.from_file(clip / "calib.txt"), name="pushed")
    for time_s, image in clip_frames(clip, 20):
        vo.push(image, time_s)
    vo.close()
    vo.trajectory().save(tmp_path / "pushed")
    assert (tmp_path / "pushed" / "pushed.txt").read_text() == (tmp_path / "whole" / "06.txt").read_text()
    assert summary["frames"] == 20 and summary["metrics"]["t_err_percent"] is not None
    assert (tmp_path / "whole" / "eval_06" / "metrics.json").is_file()
    assert (tmp_path / "pushed" / "pushed_steps.csv").is_file()
    with pytest.raises(FlowvoError, match="holds an earlier result"):
        whole.save(tmp_path / "whole")
    for folder in ("whole", "pushed"):
        assert load_run(tmp_path / folder).summary["frames"] == 20
        outputs = read_drive_outputs(tmp_path / folder)
        assert outputs.frames == 20 and outputs.path_length_m > 20
    assert write_report([tmp_path / "whole", tmp_path / "pushed"], tmp_path / "report").name == "index.html"
    rows = [summarize(Drive(name, "kitti", str(clip.parents[1]), "06"), {}, "ok",
                      outputs=read_drive_outputs(tmp_path / name)) for name in ("whole", "pushed")]
    page = write_index(tmp_path, rows, {"ok": 2}).read_text()
    assert "whole" in page and "pushed" in page and page.count("<tr class='ok'>") == 2


def test_trajectory_saves_kitti_tum_and_mcap(clip, tmp_path):
    trajectory = flowvo.run(clip, method="classical", max_frames=10)
    trajectory.save_kitti(tmp_path / "t.txt")
    assert flowvo.evaluate(tmp_path / "t.txt", trajectory, lengths=(5,)).ate_rmse_m < 1e-8  # 10 digits kept
    stamps = [float(line.split()[0]) for line in trajectory.save_tum(tmp_path / "t.tum").read_text().splitlines()]
    assert stamps == pytest.approx(trajectory.times_s.tolist(), abs=1e-9)
    with pytest.raises(FlowvoError, match="holds an earlier result"):
        trajectory.save_kitti(tmp_path / "t.txt")
    pytest.importorskip("rosbags", reason="MCAP needs the ros extra")
    from mcap.reader import make_reader

    with trajectory.save_mcap(tmp_path / "t.mcap").open("rb") as handle:
        odometry = [message for _, channel, message in make_reader(handle).iter_messages()
                    if channel.topic == "/flowvo/odom"]
    assert len(odometry) == 10


def test_import_flowvo_loads_neither_torch_nor_opencv():
    code = ("import sys, flowvo; flowvo.Camera; flowvo.run; flowvo.evaluate; "
            "assert 'torch' not in sys.modules, 'torch'; print(sorted(flowvo.__all__))")
    light = subprocess.run([sys.executable, "-c", "import sys, flowvo; assert 'cv2' not in sys.modules and "
                            "'torch' not in sys.modules"], capture_output=True, text=True)
    assert light.returncode == 0, light.stderr
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


def doc_blocks(path: Path) -> list[str]:
    """The runnable ``python`` blocks of a Markdown file (``python no-run`` blocks left out)."""
    return re.findall(r"^```python\n(.*?)^```$", path.read_text(), flags=re.S | re.M)


def tiny_clip(root: Path, clip: Path, frames: int) -> None:
    """The first ``frames`` frames of clip 06 in the KITTI layout under ``root`` (images linked, not copied)."""
    sequence = root / "sequences" / "06"
    (sequence / "image_0").mkdir(parents=True)
    for index in range(frames):
        (sequence / "image_0" / f"{index:06d}.png").symlink_to(clip / "image_0" / f"{index:06d}.png")
    (sequence / "calib.txt").write_text((clip / "calib.txt").read_text())
    (sequence / "times.txt").write_text("".join((clip / "times.txt").read_text().splitlines(True)[:frames]))
    (root / "poses").mkdir()
    truth = (clip.parents[1] / "poses" / "06.txt").read_text().splitlines(True)
    (root / "poses" / "06.txt").write_text("".join(truth[:frames]))


def test_the_examples_of_docs_api_md_run(clip, tmp_path, monkeypatch):
    pytest.importorskip("rerun", reason="the doc's live-view example needs the rerun extra")
    tiny_clip(tmp_path / "kitti_clips", clip, 14)
    writer = cv2.VideoWriter(str(tmp_path / "drive.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (1226, 370))
    for _, image in clip_frames(clip, 14):
        writer.write(cv2.cvtColor(image, cv2.COLOR_GRAY2BGR))
    writer.release()
    monkeypatch.chdir(tmp_path)
    blocks = doc_blocks(ROOT / "docs" / "api.md")
    assert len(blocks) >= 6
    namespace: dict = {"__name__": "docs_api"}
    for number, block in enumerate(blocks):
        try:
            exec(compile(block, f"docs/api.md block {number + 1}", "exec"), namespace)
        except Exception as error:
            raise AssertionError(f"docs/api.md block {number + 1} failed: {error!r}\n{block}") from error
