"""A rolling shutter's road (flowvo.odometry.rolling_shutter): exact correspondences of a flat road seen by a camera
that exposes its rows one after another while it drives straight on give the step's true length once each point's
baseline is its own; with the frames' interval as every point's baseline they read it long."""

import numpy as np
import pytest

from flowvo.camera import Camera, CameraIntrinsics
from flowvo.cli import main
from flowvo.odometry.road_length import RoadLength
from flowvo.odometry.rolling_shutter import baseline_shares
from flowvo.odometry.two_view import EssentialMotion

HW = (188, 620)
K = np.array([[359.0, 0.0, 303.0], [0.0, 359.0, 92.0], [0.0, 0.0, 1.0]])
HEIGHT_M = 1.65
FRAME_S = 0.1
SPEED_MPS = 10.0


def test_a_global_shutter_gives_every_point_the_spans_baseline():
    rows_key, rows_current = np.array([120.0, 150.0]), np.array([131.0, 187.0])
    np.testing.assert_array_equal(baseline_shares(rows_key, rows_current, 188, 0.0, 0.1), [1.0, 1.0])
    # a point 47 rows lower, read out over 30 ms of a 188-row frame, was seen 7.5 ms later: over 107.5 of 100 ms
    np.testing.assert_allclose(baseline_shares(np.array([100.0]), np.array([147.0]), 188, 0.03, 0.1), [1.075],
                               rtol=1e-15)


def seen_by_rolling_shutter(points_m: np.ndarray, frame: int, readout_s: float) -> np.ndarray:
    """Where road points (N, 3) of the first camera's frame appear in frame ``frame`` of a camera driving straight on
    at SPEED_MPS whose row ``y`` is exposed ``y / H * readout_s`` after the frame's start (pixels (N, 2)): the row
    and the time it is seen at agree (a fixed point, reached to 1e-12 px)."""
    row = np.full(len(points_m), HW[0] / 2.0)
    for _ in range(60):
        time_s = frame * FRAME_S + row / HW[0] * readout_s
        camera = points_m - np.c_[np.zeros((len(row), 2)), SPEED_MPS * time_s]
        pixels = camera @ K.T
        pixels = pixels[:, :2] / pixels[:, 2:]
        if np.abs(pixels[:, 1] - row).max() < 1e-12:
            break
        row = pixels[:, 1]
    return pixels


@pytest.mark.parametrize("readout_s", [0.0, 0.03, 0.08])
def test_the_road_seen_by_a_rolling_shutter_gives_the_true_step_once_each_point_has_its_baseline(readout_s):
    """Road points 6-30 m ahead, 2 m either side: the step of one frame (1 m) from the road plane."""
    x, z = np.meshgrid(np.linspace(-2.0, 2.0, 9), np.linspace(6.0, 30.0, 25))
    road = np.c_[x.ravel(), np.full(x.size, HEIGHT_M), z.ravel()]
    key, current = seen_by_rolling_shutter(road, 0, readout_s), seen_by_rolling_shutter(road, 1, readout_s)
    straight = EssentialMotion(np.eye(3), np.array([0.0, 0.0, -1.0]), np.ones(len(road), bool))
    shares = baseline_shares(key[:, 1], current[:, 1], HW[0], readout_s, FRAME_S)
    lengths = {}
    for name, given in (("own", shares), ("the frames'", None)):
        _, lengths[name] = RoadLength(K, HEIGHT_M, 0.0, 0.0, 0.0).measure((key, current), straight, True, given)
    assert lengths["own"] == pytest.approx(SPEED_MPS * FRAME_S, rel=1e-9)
    if readout_s:
        assert lengths["the frames'"] > 1.02 * SPEED_MPS * FRAME_S  # the near road, seen later, reads nearer
    else:
        assert lengths["the frames'"] == lengths["own"]


def test_a_cameras_readout_time_is_kept_through_scaling_and_recorded():
    camera = Camera(CameraIntrinsics(700.0, 700.0, 600.0, 180.0), readout_ms=30.0)
    assert camera.scaled(0.5, 0.5).readout_ms == 30.0
    assert camera.record()["readout_ms"] == 30.0
    assert Camera(CameraIntrinsics(700.0, 700.0, 600.0, 180.0)).record()["readout_ms"] == 0.0


def test_a_readout_longer_than_the_frame_interval_is_refused_in_one_line(real_clips, tmp_path, capsys):
    """Real clip 06 runs at 10 Hz: a readout of 150 ms cannot be; 100 ms (the whole interval) can."""
    out = tmp_path / "run"
    code = main(["-q", "run", "--data", str(real_clips), "--sequence", "06", "--max-frames", "3", "--readout-ms", "150",
                 "--out", str(out)])
    error = capsys.readouterr().err.strip().splitlines()
    assert code != 0 and len(error) == 1
    assert "--readout-ms 150: longer than the 103.6 ms between the first two frames" in error[0]
    assert not (out / "06.txt").exists()
    assert main(["-q", "run", "--data", str(real_clips), "--sequence", "06", "--max-frames", "3", "--readout-ms",
                 "100", "--out", str(out)]) == 0
