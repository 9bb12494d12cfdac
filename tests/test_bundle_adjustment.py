"""The local bundle adjustment (flowvo.odometry.bundle_adjustment) on exact synthetic cases: noise-free tracks
give the true
poses and points back, the robust loss rejects wrong tracks, and the steps' priors hold the scale."""

import numpy as np
import pytest

from flowvo.geometry import relative_motions, so3_exp
from flowvo.odometry.bundle_adjustment import adjust_bundle, reprojection_errors_px

K = np.array([[700.0, 0.0, 310.0], [0.0, 700.0, 94.0], [0.0, 0.0, 1.0]])
LOOSE = np.array([0.01, 0.01, 0.01, 0.05, 0.05, 0.05])  # rad and m: the priors barely hold the steps
FAR_START_ITERATIONS = 20  # from a start this far off (the stage starts each solve where the last one ended)


def _scene(frames: int = 6, points: int = 200, seed: int = 0):
    """A car driving 1 m a frame while turning 1.1 degrees a frame, points 8-60 m ahead, every point seen in every
    frame: true poses (N, 4, 4), points (P, 3), and the exact observations (frame, point, px)."""
    rng = np.random.default_rng(seed)
    T = np.stack([np.eye(4)] * frames)
    for i in range(frames):
        T[i, :3, :3] = so3_exp(np.array([0.001, 0.02, 0.0]) * i)
        T[i, :3, 3] = np.array([0.05, 0.01, 1.0]) * i
    world = np.column_stack([rng.uniform(-15, 15, points), rng.uniform(-3, 1.6, points), rng.uniform(8, 60, points)])
    frame, point = np.repeat(np.arange(frames), points), np.tile(np.arange(points), frames)
    T_cam_world = np.linalg.inv(T)[frame]
    in_camera = np.einsum("oij,oj->oi", T_cam_world[:, :3, :3], world[point]) + T_cam_world[:, :3, 3]
    assert np.all(in_camera[:, 2] > 1.0)
    projected = in_camera @ K.T
    return T, world, frame, point, projected[:, :2] / projected[:, 2:3], rng


def _perturbed(T: np.ndarray, world: np.ndarray, rng: np.random.Generator):
    """A start 0.2 degrees and 3 cm off per pose (the first kept), 0.3 m off per point."""
    start = T.copy()
    for i in range(1, len(T)):
        start[i, :3, :3] = so3_exp(rng.normal(0.0, 0.0035, 3)) @ T[i, :3, :3]
        start[i, :3, 3] += rng.normal(0.0, 0.03, 3)
    return start, world + rng.normal(0.0, 0.3, world.shape)


def test_noise_free_tracks_give_the_true_poses_and_points_back():
    T, world, frame, point, px, rng = _scene()
    start, start_world = _perturbed(T, world, rng)
    steps = len(T) - 1
    result = adjust_bundle(start, start_world, frame, point, px, K, relative_motions(T), np.tile(LOOSE, (steps, 1)),
                           max_iterations=FAR_START_ITERATIONS)
    assert np.sqrt(np.mean(reprojection_errors_px(start, start_world, frame, point, px, K) ** 2)) > 10.0
    np.testing.assert_allclose(result.T_world_cam, T, atol=1e-6)
    np.testing.assert_allclose(result.points_world, world, atol=1e-6)
    assert result.inlier.all() and result.rms_after_px < 1e-6
    assert np.all(reprojection_errors_px(T, world, frame, point, px, K) < 1e-9)


def test_the_robust_loss_rejects_wrong_tracks_that_plain_least_squares_follows():
    T, world, frame, point, px, rng = _scene(seed=1)
    wrong = rng.random(len(px)) < 0.1  # one observation in ten moved 5-30 px, in any direction
    angle = rng.uniform(0.0, 2.0 * np.pi, wrong.sum())
    px = px.copy()
    px[wrong] += rng.uniform(5.0, 30.0, wrong.sum())[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    start, start_world = _perturbed(T, world, rng)
    priors = relative_motions(T), np.tile(LOOSE, (len(T) - 1, 1))
    robust = adjust_bundle(start, start_world, frame, point, px, K, *priors, max_iterations=FAR_START_ITERATIONS)
    plain = adjust_bundle(start, start_world, frame, point, px, K, *priors, loss="none",
                          max_iterations=FAR_START_ITERATIONS)
    robust_error = np.abs(robust.T_world_cam - T).max()
    assert robust_error < 1e-3  # metres, and rotation matrix entries
    assert np.abs(plain.T_world_cam - T).max() > 5 * robust_error
    np.testing.assert_array_equal(robust.inlier, ~wrong)


def test_the_steps_priors_hold_the_scale_that_the_reprojections_leave_free():
    T, world, frame, point, px, _ = _scene(seed=2)
    longer = relative_motions(T)
    longer[:, :3, 3] *= 1.02  # every step 2 % longer: the same images, a scene 2 % larger
    result = adjust_bundle(T, world, frame, point, px, K, longer, np.tile(LOOSE, (len(T) - 1, 1)))
    np.testing.assert_allclose(result.T_world_cam[:, :3, 3], 1.02 * T[:, :3, 3], atol=1e-6)
    np.testing.assert_allclose(result.points_world, 1.02 * world, rtol=1e-5)  # far points: LM stops close by


def test_the_first_poses_are_held_where_they_are():
    T, world, frame, point, px, rng = _scene(seed=3)
    start, start_world = _perturbed(T, world, rng)
    start[1] = T[1]
    start[1, :3, 3] += 0.05  # held 5 cm off: the points cannot all fit
    result = adjust_bundle(start, start_world, frame, point, px, K, relative_motions(T),
                           np.tile(LOOSE, (len(T) - 1, 1)), fixed_frames=2)
    np.testing.assert_allclose(result.T_world_cam[:2], start[:2], atol=1e-12)
    assert result.rms_after_px > 0.1


def test_mismatched_priors_are_refused():
    T, world, frame, point, px, _ = _scene(frames=3, points=10)
    with pytest.raises(ValueError, match="3 poses need"):
        adjust_bundle(T, world, frame, point, px, K, relative_motions(T)[:1], np.tile(LOOSE, (1, 1)))
    with pytest.raises(ValueError, match="loss must be"):
        adjust_bundle(T, world, frame, point, px, K, relative_motions(T), np.tile(LOOSE, (2, 1)), loss="l1")
