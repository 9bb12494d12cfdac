"""The focal length and lens from the motion: exact on a turning camera, with or without a barrel lens,
refused on a straight one or where the turns cannot tell the focal length from the lens; parts of the frame
that do not move left out; tracked pairs; ``flowvo run`` on a video without intrinsics estimates, records
and prints them in pixels of the frames as decoded, or refuses in one line."""

import json

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from flowvo.calibration.focal_from_motion import estimate_focal, principal_point
from flowvo.calibration.motion_pairs import PointPair, motion_pairs, without_still_regions
from flowvo.camera import NO_DISTORTION, CameraIntrinsics, LensDistortion, distort_points, undistort_points
from flowvo.cli import main
from flowvo.kitti.sequence import KittiSequence
from flowvo.synth.dataset import synthesize
from flowvo.synth.sequence_writer import intrinsics

SIZE_HW = (188, 620)
BARREL = LensDistortion("plumb_bob", (-0.25, 0.05, 0.0, 0.0))  # the synthetic strong lens of docs/synthetic_cameras.md


def projected_pairs(focal_px: float, yaws_deg: list[float], forward_m: float, noise_px: float,
                    lens: LensDistortion = NO_DISTORTION, far_fraction: float = 0.2, seed: int = 0,
                    still_rows_px: float = 0.0) -> list[PointPair]:
    """Pairs of a camera (principal point at the centre, through ``lens``) that turns by each of
    ``yaws_deg`` about its y axis while moving ``forward_m``: random points 4-40 m ahead (``far_fraction`` of
    them 1000 times farther), seen in both frames, with Gaussian pixel noise; with ``still_rows_px``, that many
    bottom rows hide the scene and hold points 8 px apart that do not move (a bonnet)."""
    rng = np.random.default_rng(seed)
    h, w = SIZE_HW
    K = CameraIntrinsics(focal_px, focal_px, *principal_point(SIZE_HW)).K
    pairs = []
    for i, yaw_deg in enumerate(yaws_deg):
        X = np.c_[rng.uniform(-30, 30, 900), rng.uniform(-6, 1.6, 900), rng.uniform(4, 40, 900)]
        X[rng.random(900) < far_fraction] *= 1000
        R = Rotation.from_euler("y", yaw_deg, degrees=True).as_matrix()  # X2 = R X1 + t
        X2 = X @ R.T - R @ np.array([0.0, 0.0, forward_m])
        seen = []
        for points in (X, X2):
            px = points @ K.T
            seen.append(distort_points(px[:, :2] / px[:, 2:], K, lens))
        inside = (X[:, 2] > 1) & (X2[:, 2] > 1) & np.all(
            [(p[:, 0] >= 0) & (p[:, 0] < w) & (p[:, 1] >= 0) & (p[:, 1] < h - still_rows_px) for p in seen], axis=0)
        first, second = (p[inside] + rng.normal(0, noise_px, (inside.sum(), 2)) for p in seen)
        if still_rows_px:
            grid = np.meshgrid(np.arange(4.0, w, 8.0), np.arange(h - still_rows_px + 4.0, h, 8.0))
            bonnet = np.c_[grid[0].ravel(), grid[1].ravel()]
            first = np.r_[first, bonnet]
            second = np.r_[second, bonnet + rng.normal(0, 0.3, bonnet.shape)]
        pairs.append(PointPair(3 * i, 3 * i + 5, first.astype(np.float32), second.astype(np.float32)))
    return pairs


TURNS_DEG = [12, -15, 20, -10, 15, -20]


@pytest.mark.parametrize("focal_px", [250.0, 600.0])
def test_a_turning_pinhole_camera_gives_its_focal_length_and_no_distortion(focal_px):
    estimate = estimate_focal(projected_pairs(focal_px, TURNS_DEG, forward_m=2.0, noise_px=0.2), SIZE_HW)
    assert estimate.observable and estimate.reason == ""
    assert estimate.focal_px == pytest.approx(focal_px, rel=0.015)
    assert abs(np.log(estimate.focal_px / focal_px)) < 2 * estimate.relative_uncertainty  # covered at 2 sigma
    assert estimate.pairs_used == len(TURNS_DEG) and estimate.lens_estimated
    assert estimate.lens_lambda == 0.0 and estimate.distortion.is_none  # no lens told apart from none
    parts = estimate.uncertainty_parts
    assert parts["principal_point"] > 0.0
    assert estimate.relative_uncertainty == pytest.approx(np.sqrt(sum(v**2 for v in parts.values())))


def test_a_turning_camera_through_a_barrel_lens_gives_its_focal_length_and_its_lens():
    focal_px = 360.0  # KITTI's field of view at 620 px wide
    estimate = estimate_focal(projected_pairs(focal_px, TURNS_DEG, forward_m=2.0, noise_px=0.2, lens=BARREL), SIZE_HW)
    assert estimate.observable
    error = np.log(estimate.focal_px / focal_px)
    assert abs(error) < 0.05 and abs(error) < estimate.relative_uncertainty
    assert estimate.lens_lambda < -0.15 and estimate.uncertainty_parts["lens_model"] > 0.01
    K = CameraIntrinsics(focal_px, focal_px, *principal_point(SIZE_HW)).K
    K_estimated = CameraIntrinsics(estimate.focal_px, estimate.focal_px, *principal_point(SIZE_HW)).K
    frame_px = np.array([[0.0, 0.0], [619.0, 187.0], [0.0, 94.0], [150.0, 40.0], [500.0, 150.0]])
    true_rays = undistort_points(frame_px, K, BARREL) - K[:2, 2]
    rays = undistort_points(frame_px, K_estimated, estimate.distortion) - K[:2, 2]
    np.testing.assert_allclose(rays / estimate.focal_px, true_rays / focal_px, atol=0.04)  # viewing directions
    # within 2 deg at the corners of a 100 deg wide view


def test_left_out_the_lens_a_barrel_lens_reads_as_a_longer_focal_length():
    pairs = projected_pairs(360.0, TURNS_DEG, forward_m=2.0, noise_px=0.2, lens=BARREL)
    pinhole = estimate_focal(pairs, SIZE_HW, distortion=LensDistortion("plumb_bob", (1e-9, 0.0, 0.0, 0.0)))
    told = estimate_focal(pairs, SIZE_HW, distortion=BARREL)  # the lens given (--dist): only f estimated
    assert not told.lens_estimated and told.lens_lambda is None and told.uncertainty_parts["lens_model"] == 0.0
    assert told.focal_px == pytest.approx(360.0, rel=0.02)
    assert not pinhole.observable or pinhole.focal_px > 1.2 * 360.0


def test_a_straight_drive_does_not_show_the_focal_length():
    estimate = estimate_focal(projected_pairs(400.0, [0.0] * 6, forward_m=2.0, noise_px=0.2), SIZE_HW)
    assert not estimate.observable and estimate.focal_px is None and estimate.relative_uncertainty is None
    assert "turns too little" in estimate.reason and estimate.max_rotation_deg < 1.0


def test_gentle_turns_through_a_strong_lens_are_refused_not_guessed():
    pairs = projected_pairs(360.0, [5.0, -5.0, 5.0, -5.0], forward_m=0.2, noise_px=0.5, lens=BARREL, far_fraction=1.0)
    estimate = estimate_focal(pairs, SIZE_HW)
    assert not estimate.observable and estimate.focal_px is None
    assert "not pinned down" in estimate.reason or "wide range of focal lengths" in estimate.reason


def test_no_pairs_is_not_observable():
    estimate = estimate_focal([], SIZE_HW)
    assert not estimate.observable and "no two frames" in estimate.reason


def test_the_estimate_scales_with_the_frames():
    estimate = estimate_focal(projected_pairs(300.0, [15, -15, 15], forward_m=2.0, noise_px=0.1), SIZE_HW)
    doubled = estimate_focal(projected_pairs(300.0, [15, -15, 15], forward_m=2.0, noise_px=0.1), SIZE_HW,
                             frame_scale=2.0)
    assert doubled.focal_px == pytest.approx(2 * estimate.focal_px) == pytest.approx(estimate.scaled(2.0).focal_px)
    assert doubled.radius_px == pytest.approx(2 * estimate.radius_px)
    assert doubled.relative_uncertainty == estimate.relative_uncertainty


def test_a_part_of_the_frame_that_never_moves_is_left_out():
    pairs = projected_pairs(360.0, [10, -10, 12, -12] * 2, forward_m=2.0, noise_px=0.2, still_rows_px=28)
    kept, share = without_still_regions(pairs, SIZE_HW)
    assert share == pytest.approx(3 / 12)  # the two bottom rows of 16 px cells (rows 160-188 of 188), and
    # the row above them
    for pair, before in zip(kept, pairs, strict=True):
        above = (before.first_px[:, 1] < 144) & (before.second_px[:, 1] < 144)  # seen outside those rows
        np.testing.assert_array_equal(pair.first_px, before.first_px[above])
    clean = projected_pairs(360.0, [10, -10, 12, -12] * 2, forward_m=2.0, noise_px=0.2)
    assert without_still_regions(clean, SIZE_HW) == (clean, 0.0)


def test_a_bonnet_in_view_does_not_move_the_estimate():
    pairs = projected_pairs(360.0, TURNS_DEG + TURNS_DEG[:2], forward_m=2.0, noise_px=0.2, still_rows_px=28)
    estimate = estimate_focal(pairs, SIZE_HW)
    assert estimate.still_share > 0.1
    assert estimate.focal_px == pytest.approx(360.0, rel=0.02)


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


def write_drive_video(root, yaw_deg_per_frame: float, frames: int = 30, enlarge: int = 1):
    """A lossless video of a synthetic suburban drive at 620x188 (times ``enlarge``) turning by
    ``yaw_deg_per_frame``, 1 m a frame; and the true focal length in its pixels."""
    poses, position, yaw = [], np.zeros(3), 0.0
    for _ in range(frames):
        R = Rotation.from_euler("y", yaw, degrees=True).as_matrix()
        poses.append(np.c_[R, position].ravel())
        position, yaw = position + R @ [0.0, 0.0, 1.0], yaw + yaw_deg_per_frame
    np.savetxt(root / "path.txt", poses)
    synthesize(root / "data", ["00"], trajectory=root / "path.txt", scale=0.5, scene="suburban", workers=1)
    sequence = KittiSequence(root / "data", "00")
    first = sequence.read_image(0)
    size_wh = (first.shape[1] * enlarge, first.shape[0] * enlarge)
    video = root / "drive.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"FFV1"), 10.0, size_wh)
    for i in range(len(sequence)):
        image = cv2.resize(sequence.read_image(i), size_wh, interpolation=cv2.INTER_CUBIC)
        writer.write(cv2.cvtColor(image, cv2.COLOR_GRAY2BGR))
    writer.release()
    return video, intrinsics(0.5)[0][0, 0] * enlarge


def test_run_on_a_video_without_intrinsics_estimates_records_and_prints_in_the_frames_pixels(tmp_path, capsys):
    video, true_focal_px = write_drive_video(tmp_path, yaw_deg_per_frame=2.0, enlarge=2)  # 1240x376, tracked at 620
    out = tmp_path / "out"
    assert main(["-q", "run", "--video", str(video), "--out", str(out), "--method", "flowvo-geometry",
                 "--camera-height", "1.5"]) == 0
    camera = json.loads((out / "run.json").read_text())["camera"]
    estimate = camera["estimate"]
    assert camera["source"] == "estimated" and camera["camera_height_m"] == 1.5  # given options still apply
    assert camera["fx"] == camera["fy"] == pytest.approx(estimate["focal_px"])
    assert (camera["cx"], camera["cy"]) == principal_point((376, 1240))
    assert estimate["image_size"] == [1240, 376] and "1240x376 frames as decoded" in estimate["pixels"]
    error = abs(np.log(estimate["focal_px"] / true_focal_px))
    assert error < 2 * estimate["relative_uncertainty"]  # the synthetic principal point is KITTI's, 1 % of
    # the width off centre
    assert estimate["observable"] and estimate["frames"] == 30 and estimate["pairs_used"] >= 3
    assert estimate["lens"]["radius_px"] == pytest.approx(np.hypot(1240, 376) / 2)
    line = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("estimated focal length"))
    assert line.startswith(f"estimated focal length {estimate['focal_px']:.0f} px (+- ")
    assert "in pixels of the 1240x376 frames as decoded; next time pass " \
           f"--fx {camera['fx']:.1f} --fy {camera['fy']:.1f} --cx 619.5 --cy 187.5" in line


def test_run_on_a_straight_video_without_intrinsics_refuses_in_one_line(tmp_path, capsys):
    video, _ = write_drive_video(tmp_path, yaw_deg_per_frame=0.0, frames=20)
    assert main(["run", "--video", str(video), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "drive.avi: no camera intrinsics, and the focal length cannot be estimated" in err[0]
    assert "turns too little" in err[0] and "flowvo calibrate" in err[0] and "--fx --fy --cx --cy" in err[0]
    assert "--dist" in err[0] and "620x188 frames" in err[0]
    assert not (tmp_path / "out").exists()
