"""The focal length from the motion: exact on a turning camera, refused on a straight one; tracked pairs;
``flowvo run`` on a video without intrinsics estimates, records and prints it, or refuses in one line."""

import json

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from flowvo.calibration.focal_from_motion import estimate_focal, principal_point
from flowvo.calibration.motion_pairs import PointPair, motion_pairs
from flowvo.cli import main
from flowvo.kitti.sequence import KittiSequence
from flowvo.synth.dataset import synthesize
from flowvo.synth.sequence_writer import intrinsics

SIZE_HW = (188, 620)


def projected_pairs(focal_px: float, yaws_deg: list[float], forward_m: float, noise_px: float,
                    far_fraction: float = 0.2, seed: int = 0) -> list[PointPair]:
    """Pairs of a pinhole camera (principal point at the centre) that turns by each of ``yaws_deg`` about
    its y axis while moving ``forward_m``: random points 4-40 m ahead (``far_fraction`` of them 1000 times
    farther), seen in both frames, with Gaussian pixel noise."""
    rng = np.random.default_rng(seed)
    h, w = SIZE_HW
    cx, cy = principal_point(SIZE_HW)
    K = np.array([[focal_px, 0, cx], [0, focal_px, cy], [0, 0, 1]])
    pairs = []
    for i, yaw_deg in enumerate(yaws_deg):
        X = np.c_[rng.uniform(-15, 15, 600), rng.uniform(-3, 1.6, 600), rng.uniform(4, 40, 600)]
        X[rng.random(600) < far_fraction] *= 1000
        R = Rotation.from_euler("y", yaw_deg, degrees=True).as_matrix()  # X2 = R X1 + t
        X2 = X @ R.T - R @ np.array([0.0, 0.0, forward_m])
        seen = []
        for points in (X, X2):
            px = points @ K.T
            seen.append(px[:, :2] / px[:, 2:])
        inside = (X2[:, 2] > 1) & np.all([(p[:, 0] >= 0) & (p[:, 0] < w) & (p[:, 1] >= 0) & (p[:, 1] < h)
                                          for p in seen], axis=0)
        first, second = (p[inside] + rng.normal(0, noise_px, (inside.sum(), 2)) for p in seen)
        pairs.append(PointPair(3 * i, 3 * i + 5, first.astype(np.float32), second.astype(np.float32)))
    return pairs


@pytest.mark.parametrize("focal_px", [250.0, 600.0])
def test_a_turning_camera_gives_its_focal_length_within_one_percent(focal_px):
    pairs = projected_pairs(focal_px, [12, -15, 20, -10, 15, -20], forward_m=2.0, noise_px=0.2)
    estimate = estimate_focal(pairs, SIZE_HW)
    assert estimate.observable and estimate.reason == ""
    assert estimate.focal_px == pytest.approx(focal_px, rel=0.01)
    assert estimate.pairs_used == len(pairs)
    assert estimate.bootstrap_uncertainty < 0.01 < estimate.relative_uncertainty < 0.03  # + the model's 2 %


def test_a_straight_drive_does_not_show_the_focal_length():
    estimate = estimate_focal(projected_pairs(400.0, [0.0] * 6, forward_m=2.0, noise_px=0.2), SIZE_HW)
    assert not estimate.observable and estimate.focal_px is None and estimate.relative_uncertainty is None
    assert "turns too little" in estimate.reason and estimate.max_rotation_deg < 1.0


def test_no_pairs_is_not_observable():
    estimate = estimate_focal([], SIZE_HW)
    assert not estimate.observable and "no two frames" in estimate.reason


def test_the_estimate_scales_with_the_frames():
    estimate = estimate_focal(projected_pairs(300.0, [15, -15, 15], forward_m=2.0, noise_px=0.1), SIZE_HW)
    assert estimate.scaled(2.0).focal_px == pytest.approx(2 * estimate.focal_px)
    assert estimate.scaled(2.0).relative_uncertainty == estimate.relative_uncertainty


def test_motion_pairs_follow_points_until_they_leave_the_view():
    texture = cv2.GaussianBlur(np.random.default_rng(1).integers(0, 256, (188, 720), dtype=np.uint8), (3, 3), 0)
    frames = [np.ascontiguousarray(texture[:, 10 * i : 10 * i + 320]) for i in range(40)]  # 10 px left a frame
    pairs = motion_pairs(frames)
    assert [p.first for p in pairs[:3]] == [0, 4, 8]  # a new chain once the newest moved 40 px
    assert any(p.second < 39 for p in pairs)  # chains end as their points leave the view, others at the end
    for pair in pairs:
        assert pair.second > pair.first and len(pair.first_px) >= 60
        shift = pair.second_px - pair.first_px
        np.testing.assert_allclose(np.median(shift, axis=0), [-10.0 * (pair.second - pair.first), 0.0], atol=0.1)


def write_drive_video(root, yaw_deg_per_frame: float, frames: int = 30):
    """A lossless video of a synthetic suburban drive at 620x188 turning by ``yaw_deg_per_frame``, 1 m a
    frame; and the true focal length."""
    poses, position, yaw = [], np.zeros(3), 0.0
    for _ in range(frames):
        R = Rotation.from_euler("y", yaw, degrees=True).as_matrix()
        poses.append(np.c_[R, position].ravel())
        position, yaw = position + R @ [0.0, 0.0, 1.0], yaw + yaw_deg_per_frame
    np.savetxt(root / "path.txt", poses)
    synthesize(root / "data", ["00"], trajectory=root / "path.txt", scale=0.5, scene="suburban", workers=1)
    sequence = KittiSequence(root / "data", "00")
    first = sequence.read_image(0)
    video = root / "drive.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"FFV1"), 10.0, first.shape[::-1])
    for i in range(len(sequence)):
        writer.write(cv2.cvtColor(sequence.read_image(i), cv2.COLOR_GRAY2BGR))
    writer.release()
    return video, intrinsics(0.5)[0][0, 0]


def test_run_on_a_video_without_intrinsics_estimates_records_and_prints_the_focal_length(tmp_path, capsys):
    video, true_focal_px = write_drive_video(tmp_path, yaw_deg_per_frame=2.0)
    out = tmp_path / "out"
    assert main(["-q", "run", "--video", str(video), "--out", str(out), "--method", "flowvo-geometry",
                 "--camera-height", "1.5"]) == 0
    camera = json.loads((out / "run.json").read_text())["camera"]
    estimate = camera["estimate"]
    assert camera["source"] == "estimated" and camera["camera_height_m"] == 1.5  # given options still apply
    assert camera["fx"] == camera["fy"] == pytest.approx(estimate["focal_px"])
    assert (camera["cx"], camera["cy"]) == principal_point((188, 620))
    assert estimate["focal_px"] == pytest.approx(true_focal_px, rel=0.1)  # the synthetic principal point is
    # KITTI's, 1 % of the width off centre
    assert estimate["observable"] and estimate["frames"] == 30 and estimate["pairs_used"] >= 3
    lines = capsys.readouterr().out.splitlines()
    assert any(line.startswith(f"estimated focal length {estimate['focal_px']:.0f} px (+- ") and
               f"frame pairs in the first 30 frames; next time pass --fx {camera['fx']:.1f}" in line for line in lines)


def test_run_on_a_straight_video_without_intrinsics_refuses_in_one_line(tmp_path, capsys):
    video, _ = write_drive_video(tmp_path, yaw_deg_per_frame=0.0, frames=20)
    assert main(["run", "--video", str(video), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "drive.avi: no camera intrinsics, and the focal length cannot be estimated" in err[0]
    assert "turns too little" in err[0] and "flowvo calibrate" in err[0] and "--fx --fy --cx --cy" in err[0]
    assert not (tmp_path / "out").exists()
