import numpy as np
import pytest

from flowvo import geometry as g
from flowvo.kitti.poses import read_kitti_poses


def mirror_motion(motion: np.ndarray) -> np.ndarray:
    """The motion seen in a left-right mirrored video: ``S M S`` with ``S = diag(-1, 1, 1)``."""
    return g.MIRROR_X @ motion @ g.MIRROR_X


def test_wrap_angle_maps_into_half_open_interval():
    wrapped = g.wrap_angle_rad(np.array([np.pi, -np.pi, 3 * np.pi, 0.5, -7.0]))
    np.testing.assert_allclose(wrapped, [np.pi, np.pi, np.pi, 0.5, -7.0 + 2 * np.pi])


def test_yaw_of_yaw_rotation_is_identity_map():
    yaws = np.linspace(-3.0, 3.0, 13)
    poses = np.tile(np.eye(4), (13, 1, 1))
    poses[:, :3, :3] = g.yaw_rotation(yaws)
    np.testing.assert_allclose(g.yaw_rad(poses), yaws, atol=1e-12)
    # positive yaw turns the forward axis (z) towards +x (right)
    assert g.yaw_rotation(np.array(0.1))[0, 2] > 0


def test_relative_motions_recompose_to_poses():
    rng = np.random.default_rng(0)
    motions = g.se3_from_targets(rng.normal(scale=0.2, size=(6, 6)))
    poses = g.chain_se3(motions)
    np.testing.assert_allclose(g.relative_motions(poses), motions, atol=1e-12)


def test_planar_targets_of_constant_circle_are_exact():
    # 20 steps on a circle of radius 50 m turning right by 0.02 rad per frame
    radius, step = 50.0, 0.02
    yaws = step * np.arange(21)
    poses = np.tile(np.eye(4), (21, 1, 1))
    poses[:, :3, :3] = g.yaw_rotation(yaws)
    poses[:, 0, 3] = radius * (1 - np.cos(yaws))
    poses[:, 2, 3] = radius * np.sin(yaws)
    targets = g.planar_targets(poses)
    np.testing.assert_allclose(targets[:, 0], 2 * radius * np.sin(step / 2), rtol=1e-12)
    np.testing.assert_allclose(targets[:, 1], step, rtol=1e-12)
    # the chord of a constant-curvature arc follows the mean heading: chaining is exact
    np.testing.assert_allclose(g.chain_planar(targets), poses, atol=1e-10)


def test_heading_change_wraps_across_pi():
    poses = np.tile(np.eye(4), (2, 1, 1))
    poses[:, :3, :3] = g.yaw_rotation(np.array([3.1, -3.1]))
    assert g.planar_targets(poses)[0, 1] == pytest.approx(2 * np.pi - 6.2)


def test_planar_round_trip_reproduces_kitti_09_xz_path(kitti_poses_dir):
    gt = read_kitti_poses(kitti_poses_dir / "09.txt").T_world_cam
    chained = g.chain_planar(g.planar_targets(gt))
    error_m = np.linalg.norm(chained[:, [0, 2], 3] - gt[:, [0, 2], 3], axis=1)
    # Not exact: d_i is the 3-D step (the car climbs ~38 m), and the heading of the camera is not exactly
    # the direction of travel (pitch, roll, mounting). Over 1.7 km the x-z drift measured 5.4 m max.
    assert error_m.max() < 6.0
    assert error_m.mean() < 3.5
    assert np.all(chained[:, 1, 3] == 0.0)


def test_se3_chain_reproduces_kitti_09(kitti_poses_dir):
    gt = read_kitti_poses(kitti_poses_dir / "09.txt").T_world_cam
    chained = g.chain_se3(g.se3_from_targets(g.se3_targets(g.relative_motions(gt))))
    # the file's rotations have 7 digits, so they are orthonormal only to ~1e-7; 1591 compositions
    # accumulate that to under 2 cm
    assert np.abs(chained[:, :3, 3] - gt[:, :3, 3]).max() < 0.02


def test_so3_log_inverts_exp_including_small_angles():
    rng = np.random.default_rng(1)
    axis = np.array([0.36, -0.48, 0.8])
    vectors = np.concatenate([rng.normal(scale=0.8, size=(50, 3)), rng.normal(scale=1e-9, size=(5, 3)),
                              np.outer([np.pi / 2 - 1e-9, np.pi / 2 + 1e-9, np.pi - 1e-6], axis)])
    np.testing.assert_allclose(g.so3_log(g.so3_exp(vectors)), vectors, atol=1e-9)
    half_turn = g.so3_log(g.so3_exp(np.pi * axis))  # the axis either way: the same rotation
    np.testing.assert_allclose(np.abs(half_turn), np.pi * np.abs(axis), atol=1e-9)
    np.testing.assert_array_equal(g.so3_log(np.eye(3)), np.zeros(3))


def test_mirror_rule_for_se3_matches_reflected_motion():
    rng = np.random.default_rng(2)
    targets = rng.normal(scale=0.3, size=(10, 6))
    mirrored = np.stack([mirror_motion(m) for m in g.se3_from_targets(targets)])
    np.testing.assert_allclose(g.se3_targets(mirrored), g.mirror_targets(targets, "se3"), atol=1e-10)


def test_mirror_rule_for_planar_negates_heading_only():
    poses = g.chain_planar(np.array([[1.0, 0.05], [1.2, -0.02], [0.8, 0.1]]))
    mirrored = np.stack([g.MIRROR_X @ p @ g.MIRROR_X for p in poses])
    np.testing.assert_allclose(
        g.planar_targets(mirrored), g.mirror_targets(g.planar_targets(poses), "planar"), atol=1e-12
    )


def test_skew_is_the_cross_product():
    a, b = np.array([0.3, -1.2, 2.0]), np.array([-0.7, 0.4, 1.1])
    np.testing.assert_allclose(g.skew(a) @ b, np.cross(a, b), atol=1e-15)
    np.testing.assert_array_equal(g.skew(a), -g.skew(a).T)


def test_cross_is_numpys_exactly_with_broadcasting():
    rng = np.random.default_rng(3)
    a, b, c = rng.normal(size=(40, 3)), rng.normal(size=(40, 3)), rng.normal(size=3)
    stacked = rng.normal(size=(5, 4, 3))
    np.testing.assert_array_equal(g.cross(a, b), np.cross(a, b))
    np.testing.assert_array_equal(g.cross(c, a), np.cross(c, a))
    np.testing.assert_array_equal(g.cross(stacked, c), np.cross(stacked, c))
    np.testing.assert_array_equal(g.cross(a, b), -g.cross(b, a))
