import numpy as np
import pytest
from devkit_reference import averages, load_poses, sequence_errors

from flowvo import geometry as g
from flowvo.kitti.poses import read_kitti_poses
from flowvo.metrics import kitti_odometry as kitti
from flowvo.trajectory import Trajectory


def straight_path(n_frames: int, step_m: float) -> np.ndarray:
    poses = np.tile(np.eye(4), (n_frames, 1, 1))
    poses[:, 2, 3] = step_m * np.arange(n_frames)
    return poses


def test_last_frame_is_first_strictly_beyond_the_length():
    distances = np.arange(0.0, 10.0)
    assert kitti.last_frame_from_segment_length(distances, 2, 3.0) == 6
    assert kitti.last_frame_from_segment_length(distances, 2, 7.0) == -1


def test_constant_scale_error_gives_one_percent_of_driven_length_and_no_rotation_error():
    gt = straight_path(1001, 1.0)
    pred = gt.copy()
    pred[:, :3, 3] *= 1.01
    summary = kitti.summarize(kitti.sequence_segment_errors(Trajectory.from_poses(gt), Trajectory.from_poses(pred)))
    assert summary["r_err_deg_per_m"] == 0.0
    # The error is exactly 1 % of the driven segment, which is L + 1 m (the first frame strictly beyond
    # L); the devkit divides by the nominal L, hence 1 % x (L + 1) / L (to float32 precision, as the devkit).
    for row in summary["per_length"]:
        assert row["t_err_percent"] == pytest.approx(1.0 * (row["length_m"] + 1) / row["length_m"], rel=1e-6)


def test_constant_yaw_drift_gives_analytic_rotation_error():
    drift_rad = 1e-3
    gt = straight_path(1001, 1.0)
    pred = gt.copy()
    pred[:, :3, :3] = g.yaw_rotation(drift_rad * np.arange(1001))
    errors = kitti.sequence_segment_errors(Trajectory.from_poses(gt), Trajectory.from_poses(pred))
    # each segment spans L + 1 frames steps, so its rotation error is (L + 1) * drift, divided by L; the
    # devkit's float32 acos of a cosine near 1 holds ~6 significant digits at 0.1 rad
    np.testing.assert_allclose(errors.r_err_rad_per_m, (errors.length_m + 1) * drift_rad / errors.length_m, rtol=1e-5)


def test_speed_is_length_over_frame_time():
    errors = kitti.sequence_segment_errors(
        Trajectory.from_poses(straight_path(300, 2.0)), Trajectory.from_poses(straight_path(300, 2.0))
    )
    # 100 m at 2 m per frame: last frame is first + 51, so 52 frames of 0.1 s
    assert errors.speed_mps[errors.length_m == 100][0] == pytest.approx(100 / 5.2)


def test_per_speed_bins_need_three_segments():
    errors = kitti.SegmentErrors(
        first_frame=np.arange(5),
        r_err_rad_per_m=np.zeros(5),
        t_err=np.full(5, 0.02),
        length_m=np.full(5, 100.0),
        speed_mps=np.array([3.0, 3.5, 3.9, 20.0, 20.5]),
    )
    speeds = [row["speed_mps"] for row in kitti.summarize(errors)["per_speed"]]
    assert speeds == [2.0, 4.0]  # 3..3.9 fall in the 2 and 4 m/s bins (+-2); 20 and 22 m/s bins get fewer than 3


def test_short_trajectory_has_no_segment():
    trajectory = Trajectory.from_poses(straight_path(50, 1.0))
    with pytest.raises(ValueError, match="shorter than 100 m"):
        kitti.summarize(kitti.sequence_segment_errors(trajectory, trajectory))


@pytest.mark.parametrize("example", ["example_0", "example_1"])
@pytest.mark.parametrize("sequence", ["09", "10"])
def test_matches_independent_devkit_port_on_published_examples(
    kitti_poses_dir, example_results_dir, example, sequence
):
    gt_path = kitti_poses_dir / f"{sequence}.txt"
    pred_path = example_results_dir / example / f"{sequence}.txt"
    reference = sequence_errors(load_poses(gt_path), load_poses(pred_path))
    ref_t, ref_r = averages(reference)
    ours = kitti.summarize(kitti.sequence_segment_errors(read_kitti_poses(gt_path), read_kitti_poses(pred_path)))
    assert ours["segments"] == len(reference)
    assert ours["t_err_percent"] == pytest.approx(ref_t, rel=1e-6)
    assert ours["r_err_deg_per_m"] == pytest.approx(ref_r, rel=1e-6)


# Printed by the compiled devkit (evaluate_odometry.cpp) for the public example_1 results: t_err as a
# fraction x 100, r_err in rad/m.
COMPILED_DEVKIT_EXAMPLE_1 = {"09": (2.6068422943, 5.0214788644e-05), "10": (2.2931741551, 6.4462918090e-05)}


@pytest.mark.parametrize("sequence", sorted(COMPILED_DEVKIT_EXAMPLE_1))
def test_equals_the_compiled_devkit_on_example_1_to_1e_6(kitti_poses_dir, example_results_dir, sequence):
    ours = kitti.summarize(
        kitti.sequence_segment_errors(
            read_kitti_poses(kitti_poses_dir / f"{sequence}.txt"),
            read_kitti_poses(example_results_dir / "example_1" / f"{sequence}.txt"),
        )
    )
    t_err_percent, r_err_rad_per_m = COMPILED_DEVKIT_EXAMPLE_1[sequence]
    assert ours["t_err_percent"] == pytest.approx(t_err_percent, rel=1e-6)
    assert np.radians(ours["r_err_deg_per_m"]) == pytest.approx(r_err_rad_per_m, rel=1e-6)
    assert ours["r_err_deg_per_100m"] == pytest.approx(100 * ours["r_err_deg_per_m"])


def test_segment_errors_use_a_general_inverse_not_the_transpose():
    """A predicted rotation that is not quite orthonormal (allowed by the reader to 1e-2, as written by
    tools that print few digits) is inverted exactly as the devkit's Matrix::inv does."""
    gt = straight_path(300, 1.0)
    pred = gt.copy()
    pred[:, :3, :3] *= 1.004  # scaled rotations: R^T is no longer the inverse
    errors = kitti.sequence_segment_errors(Trajectory.from_poses(gt), Trajectory.from_poses(pred))
    # inv(P_f) P_l = [I, 101 m / 1.004 forward]: the error moves 101 (1 - 1 / 1.004) m over 100 m; with R^T
    # it would be 101 (1.004^2 - 1.004) m instead
    np.testing.assert_allclose(errors.t_err[errors.length_m == 100], 101 * (1 - 1 / 1.004) / 100, rtol=1e-5)


def test_missing_frames_skip_segments_touching_them(kitti_poses_dir):
    gt = read_kitti_poses(kitti_poses_dir / "10.txt")
    full = kitti.sequence_segment_errors(gt, gt)
    keep = np.ones(len(gt), bool)
    keep[[0, 1, 2]] = False
    partial = kitti.sequence_segment_errors(gt, gt.subset(gt.frame_ids[keep]))
    assert len(partial) == len(full) - np.sum(full.first_frame == 0)


def test_pooled_average_weights_every_segment_equally():
    a = kitti.SegmentErrors(np.zeros(3), np.zeros(3), np.full(3, 0.01), np.full(3, 100.0), np.full(3, 10.0))
    b = kitti.SegmentErrors(np.zeros(1), np.zeros(1), np.full(1, 0.05), np.full(1, 100.0), np.full(1, 10.0))
    pooled = kitti.summarize(kitti.SegmentErrors.concatenate([a, b]))
    assert pooled["t_err_percent"] == pytest.approx(2.0)
