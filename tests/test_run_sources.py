"""One drive, three containers: a KITTI folder, a lossless video and ROS bags give the same poses through
``flowvo run``; the bag run also writes a nav_msgs/Odometry MCAP. And ``bench --json``."""

import json
import sys

import cv2
import numpy as np
import pytest

from flowvo.cli import main
from flowvo.kitti.calib import read_calibration
from flowvo.kitti.sequence import KittiSequence
from flowvo.synth.dataset import synthesize

pytest.importorskip("rosbags")

from ros_bags import BagSpec, write_bag  # noqa: E402
from rosbags.highlevel import AnyReader  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    root = tmp_path_factory.mktemp("drive")
    synthesize(root, ["00"], seed=4, frames=24, scale=0.5, workers=1)  # even frame sizes: video codecs need them
    sequence = KittiSequence(root, "00")
    frames = [sequence.read_image(i) for i in range(len(sequence))]
    runs = tmp_path_factory.mktemp("runs")
    assert main(["-q", "run", "--data", str(root), "--sequence", "00", "--out", str(runs / "kitti")]) == 0
    return root, sequence, frames, runs, np.loadtxt(runs / "kitti" / "00.txt")


def test_a_video_of_the_frames_gives_the_same_poses(drive, tmp_path):
    root, sequence, frames, _, kitti_poses = drive
    video = tmp_path / "dash cam.avi"
    h, w = frames[0].shape
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"FFV1"), 10.0, (w, h))
    for frame in frames:
        writer.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR))
    writer.release()
    out = tmp_path / "out"
    assert main(["-q", "run", "--video", str(video), "--calib", str(root / "sequences/00/calib.txt"),
                 "--out", str(out)]) == 0
    np.testing.assert_allclose(np.loadtxt(out / "dash_cam.txt"), kitti_poses, atol=1e-9)
    stamps = np.loadtxt(out / "dash_cam.tum")[:, 0]
    np.testing.assert_allclose(stamps, np.arange(len(frames)) * 0.1, atol=1e-6)


def test_a_video_without_intrinsics_is_one_clear_error(drive, tmp_path, capsys):
    video = tmp_path / "v.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"FFV1"), 10.0, (64, 48))
    writer.write(np.zeros((48, 64, 3), np.uint8))
    writer.release()
    assert main(["run", "--video", str(video), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "intrinsics" in err[0]
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("kind", ["ros1", "ros2-mcap"])
def test_a_bag_of_the_frames_gives_the_same_poses_and_an_odometry_mcap(drive, tmp_path, kind):
    root, sequence, frames, _, kitti_poses = drive
    stamps_ns = [int(round(t * 1e9)) + 1_700_000_000_000_000_000 for t in sequence.times_s]
    K = read_calibration(root / "sequences/00/calib.txt").K0
    bag = write_bag(tmp_path, kind, BagSpec(frames, stamps_ns, encoding="mono8", K=K))
    out = tmp_path / "out"
    assert main(["-q", "run", "--bag", str(bag), "--topic", "/camera/image_raw",
                 "--camera-info-topic", "/camera/camera_info", "--out", str(out)]) == 0
    # the bag's stamps (1.7e9 s + t, float64) differ from times.txt by up to 2.4e-7 s: step lengths by ~1e-6
    np.testing.assert_allclose(np.loadtxt(out / "drive.txt"), kitti_poses, rtol=1e-6, atol=1e-6)
    store = get_typestore(Stores.ROS2_HUMBLE)
    with AnyReader([out / "drive.mcap"], default_typestore=store) as reader:
        odometry = [c for c in reader.connections if c.topic == "/flowvo/odom"]
        messages = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=odometry)]
    assert len(messages) == len(frames)
    last = messages[-1]
    assert last.header.stamp.sec * 10**9 + last.header.stamp.nanosec == pytest.approx(stamps_ns[-1], abs=200)
    position = last.pose.pose.position
    assert np.linalg.norm([position.x, position.y, position.z]) == pytest.approx(
        np.linalg.norm(kitti_poses[-1][[3, 7, 11]]), rel=1e-6)
    # the default method's covariances: the twist's from the step records, the pose's growing along the drive
    twist = np.array([np.diag(np.reshape(m.twist.covariance, (6, 6))) for m in messages])
    pose = np.array([np.trace(np.reshape(m.pose.covariance, (6, 6))[:3, :3]) for m in messages])
    assert (twist > 0).all() and pose[0] == 0 and np.all(np.diff(pose) > 0)


def test_bench_json_rows_start_with_the_default_method(drive, tmp_path, capsys):
    root = drive[0]
    assert main(["-q", "bench", "--data", str(root), "--sequence", "00", "--frames", "8", "--repeat", "1",
                 "--methods", "flowvo", "classical", "--json", str(tmp_path / "b.json")]) == 0
    rows = json.loads((tmp_path / "b.json").read_text())["rows"]
    assert [row["method"] for row in rows] == ["flowvo", "classical"]
    for row in rows:
        assert row["frames_per_second"] > 0 and row["label"]
        assert {"image_read_s", "flow_s", "network_s", "geometry_s", "chaining_s", "total_s"} <= set(row)
        # one run each: the ratio is that run's speed over the decoding pass just before it
        assert row["over_decoding"] == pytest.approx(row["frames_per_second"] / row["decode_frames_per_second"])
    assert "streaming / decoding, paired run by run: flowvo" in capsys.readouterr().out


def test_bad_mcap_frame_ids_are_refused_before_the_run(drive, tmp_path, capsys):
    root = drive[0]
    assert main(["run", "--data", str(root), "--sequence", "00", "--out", str(tmp_path / "o"), "--mcap",
                 "--frame-id", "/odom"]) == 2
    assert "frame id '/odom'" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_run_json_records_the_library_versions_its_trajectory_depends_on(drive):
    versions = json.loads((drive[3] / "kitti" / "run.json").read_text())["versions"]
    assert versions["opencv"] == cv2.__version__ and versions["numpy"] == np.__version__
    assert set(versions) == {"flowvo", "opencv", "numpy", "torch"}


def test_the_latency_is_chosen_and_recorded_and_refused_where_there_is_no_window(drive, tmp_path, capsys):
    root, _, frames, runs, kitti_poses = drive
    assert json.loads((runs / "kitti" / "run.json").read_text())["latency_frames"] == 5  # the default's
    at_once = tmp_path / "at_once"
    assert main(["-q", "run", "--data", str(root), "--sequence", "00", "--latency", "0", "--out", str(at_once)]) == 0
    summary = json.loads((at_once / "run.json").read_text())
    assert summary["latency_frames"] == 0 and summary["scale_window"]["latency_frames"] == 0
    poses = np.loadtxt(at_once / "00.txt")
    assert poses.shape == kitti_poses.shape and not np.allclose(poses, kitti_poses)  # the window saw less
    capsys.readouterr()
    assert main(["run", "--data", str(root), "--sequence", "00", "--method", "cnn", "--latency", "3",
                 "--out", str(tmp_path / "cnn")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--latency applies to the windowed methods" in err[0]
    assert not (tmp_path / "cnn").exists()


def test_flowvo_ba_adjusts_the_defaults_poses_behind_its_window_and_records_the_added_latency(drive, tmp_path):
    root, _, _, _, kitti_poses = drive
    out = tmp_path / "ba"
    assert main(["-q", "run", "--data", str(root), "--sequence", "00", "--method", "flowvo-ba", "--out", str(out)]) == 0
    summary = json.loads((out / "run.json").read_text())
    assert summary["latency_frames"] == 5 + 9 and summary["bundle"]["latency_frames"] == 9
    assert summary["bundle"]["solves"] == len(kitti_poses) - 2 + 1  # from the third frame (points seen thrice) on
    poses = np.loadtxt(out / "00.txt")
    assert poses.shape == kitti_poses.shape and not np.allclose(poses, kitti_poses)
    lengths = [np.linalg.norm(np.diff(p[:, [3, 7, 11]], axis=0), axis=1).sum() for p in (poses, kitti_poses)]
    assert lengths[0] == pytest.approx(lengths[1], rel=0.01)  # the scale stays the window's


def test_flowvo_ba_without_gtsam_says_what_installs_it_before_the_run(drive, tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "gtsam", None)  # as if not installed
    out = tmp_path / "ba"
    assert main(["run", "--data", str(drive[0]), "--sequence", "00", "--method", "flowvo-ba", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install 'flowvo[ba]'" in err[0] and not out.exists()
