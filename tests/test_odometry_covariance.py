"""The odometry's covariances: a step's from its length's uncertainty and the measured scatter, the poses'
chained to first order (exact cases and sampling), the drift, and the step records they come from."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm, logm

from flowvo.geometry import chain_se3, invert_se3, skew, so3_exp, so3_log
from flowvo.odometry.covariance import (
    DIRECTION_FLOOR_M,
    DIRECTION_SIGMA_RAD,
    DRIFT_FRACTION,
    DRIFT_RAD_PER_M,
    ROTATION_SIGMA_RAD,
    STANDSTILL_SIGMA_M,
    UNMEASURED_LOG_SIGMA,
    adjoint,
    chained_covariances,
    drift_covariances,
    in_parent_axes,
    records_covariances,
    step_covariances,
)
from flowvo.odometry.scale_window import StepRecord


def motion(forward_m: float, yaw_rad: float = 0.0) -> np.ndarray:
    """``T_prev_cur``: turn by ``yaw_rad`` about the camera's y axis, then move ``forward_m`` along the previous
    camera's z axis."""
    T = np.eye(4)
    T[:3, :3] = so3_exp(np.array([0.0, yaw_rad, 0.0]))
    T[:3, 3] = [0.0, 0.0, forward_m]
    return T


def hat(xi: np.ndarray) -> np.ndarray:
    """The 4x4 matrix of a twist ``(rho, phi)``: ``expm(hat(xi)) = exp(xi)``."""
    rho, phi = xi[:3], xi[3:]
    result = np.zeros((4, 4))
    result[:3, :3] = skew(phi)
    result[:3, 3] = rho
    return result


def vee(matrix: np.ndarray) -> np.ndarray:
    return np.array([*matrix[:3, 3], matrix[2, 1], matrix[0, 2], matrix[1, 0]])


def test_a_straight_step_is_uncertain_along_by_its_length_and_across_by_its_direction():
    (covariance,) = step_covariances(motion(2.0)[None], np.array([0.03]), np.array([False]))
    across = (2.0 * DIRECTION_SIGMA_RAD) ** 2 + DIRECTION_FLOOR_M**2
    np.testing.assert_allclose(covariance, np.diag([across, across, (2.0 * 0.03) ** 2, *[ROTATION_SIGMA_RAD**2] * 3]),
                               rtol=1e-12, atol=1e-18)


def test_a_turning_step_is_measured_along_its_displacement_in_the_current_camera():
    (covariance,) = step_covariances(motion(1.0, yaw_rad=0.3)[None], np.array([0.05]), np.array([False]))
    direction = so3_exp(np.array([0.0, 0.3, 0.0])).T @ np.array([0.0, 0.0, 1.0])  # the displacement, current frame
    assert direction @ covariance[:3, :3] @ direction == pytest.approx(0.05**2)
    sideways = np.cross(direction, [0.0, 1.0, 0.0])
    assert sideways @ covariance[:3, :3] @ sideways == pytest.approx(DIRECTION_SIGMA_RAD**2 + DIRECTION_FLOOR_M**2)


def test_standstill_and_unmeasured_steps():
    still, unmeasured = step_covariances(np.stack([np.eye(4), motion(1.5)]), np.array([np.nan, np.nan]),
                                         np.array([True, False]))
    np.testing.assert_allclose(still[:3, :3], STANDSTILL_SIGMA_M**2 * np.eye(3))
    assert unmeasured[2, 2] == pytest.approx((1.5 * UNMEASURED_LOG_SIGMA) ** 2)


def test_the_adjoint_moves_a_perturbation_across_a_transform():
    rng = np.random.default_rng(3)
    T = expm(hat(rng.normal(size=6)))
    xi = 1e-3 * rng.normal(size=6)
    np.testing.assert_allclose(vee(logm(T @ expm(hat(xi)) @ invert_se3(T)).real), adjoint(T) @ xi, atol=1e-12)


def test_a_heading_error_becomes_a_sideways_error_of_the_heading_times_the_distance():
    sigma_rad, forward_m = 0.01, 7.0
    first = np.zeros((6, 6))
    first[3:, 3:] = sigma_rad**2 * np.eye(3)
    covariances = chained_covariances(np.stack([np.eye(4), motion(forward_m)]), np.stack([first, np.zeros((6, 6))]))
    assert not covariances[0].any()
    np.testing.assert_allclose(np.diag(covariances[2])[:3], [(sigma_rad * forward_m) ** 2] * 2 + [0.0], atol=1e-15)


def test_chained_covariances_match_sampled_chains():
    rng = np.random.default_rng(0)
    motions = np.stack([motion(1.0 + 0.2 * k, yaw_rad=0.05 * (-1) ** k) for k in range(6)])
    steps = step_covariances(motions, np.full(6, 0.05), np.zeros(6, bool)) * 25  # large enough to measure
    predicted = chained_covariances(motions, steps)[-1]
    count = 4000
    noise = np.stack([rng.multivariate_normal(np.zeros(6), c, size=count) for c in steps], axis=1)  # (count, 6, 6)
    ends = np.eye(4)
    for k in range(len(motions)):
        ends = ends @ motions[k] @ expm(np.stack([hat(xi) for xi in noise[:, k]]))
    errors = invert_se3(chain_se3(motions)[-1]) @ ends  # (count, 4, 4): exp(xi) of each sampled chain
    sampled = np.cov(np.concatenate([errors[:, :3, 3], so3_log(errors[:, :3, :3])], axis=1).T)  # xi to first order
    scale = np.sqrt(np.outer(np.diag(predicted), np.diag(predicted)))
    assert np.max(np.abs(sampled - predicted) / scale) < 0.08  # first order, 4000 samples


def test_the_drift_grows_with_the_distance_driven():
    covariance = drift_covariances(np.array([0.0, 50.0]))
    assert not covariance[0].any()
    np.testing.assert_allclose(np.diag(covariance[1]),
                               [(DRIFT_FRACTION * 50) ** 2] * 3 + [(DRIFT_RAD_PER_M * 50) ** 2] * 3)


def test_parent_axes_turn_both_blocks():
    covariance = np.diag([1.0, 0.0, 0.0, 0.0, 0.0, 4.0])[None]
    turned = in_parent_axes(so3_exp(np.array([0.0, 0.0, np.pi / 2]))[None], covariance)[0]  # camera x -> parent y
    np.testing.assert_allclose(np.diag(turned), [0.0, 1.0, 0.0, 0.0, 0.0, 4.0], atol=1e-15)


def test_records_give_the_step_and_pose_covariances():
    T = chain_se3(np.stack([motion(1.0), np.eye(4), motion(1.0)]))
    records = [StepRecord(0.1, 1.0, 0.02, "road"), StepRecord(0.2, 0.0, None, "standstill"),
               StepRecord(0.3, 1.0, None, "none")]
    steps, poses = records_covariances(T, records)
    assert steps[0, 2, 2] == pytest.approx(0.02**2) and steps[2, 2, 2] == pytest.approx(UNMEASURED_LOG_SIGMA**2)
    np.testing.assert_allclose(steps[1, :3, :3], STANDSTILL_SIGMA_M**2 * np.eye(3))
    assert poses.shape == (4, 6, 6) and not poses[0].any()
    # chained (two steps forward, a standstill between) plus the drift over 2 m
    assert poses[3, 2, 2] == pytest.approx(0.02**2 + STANDSTILL_SIGMA_M**2 + UNMEASURED_LOG_SIGMA**2
                                           + (2 * DRIFT_FRACTION) ** 2)
