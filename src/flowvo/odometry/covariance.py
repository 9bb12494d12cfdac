"""How uncertain the odometry is, for a fusion filter: each step's covariance from its length's uncertainty
(the scale window's) and the scatter of rotations and directions measured on the real clips, and each
pose's: the steps' chained to first order, plus a drift that grows with the distance driven (the errors
that do not average out along a drive: biases of the scale and of the direction, the calibration's).

Pure functions over NumPy arrays. A covariance here is that of a right perturbation ``xi = (rho, phi)``:
the true transform is ``T exp(xi)``, ``rho`` (metres) and ``phi`` (radians) in the frame of the camera the
transform ends at (a step's: the current camera), in ROS order (x, y, z, rotation about x, y, z).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from flowvo.geometry import invert_se3, relative_motions, skew
from flowvo.odometry.scale_window import StepRecord

# Per step (10 Hz), against the truth on the real clips (309 steps of 01, 06 and 07, the default method; the
# truth's own noise is in them, so they err on the safe side):
ROTATION_SIGMA_RAD = np.radians(0.025)  # each axis: rms 0.022 (x), 0.023 (y), 0.025 deg (z)
DIRECTION_SIGMA_RAD = np.radians(0.5)  # the translation direction at speed (rms 0.39-0.46 deg above 1 m a step)
DIRECTION_FLOOR_M = 0.0035  # sideways error that does not shrink with the step: at low speed the direction
# scatters more (rms 1.5 / 1.1 / 0.8 deg at 0.1 / 0.3 / 0.55 m a step), about 0.2 deg m over the length
STANDSTILL_SIGMA_M = 0.04  # a step called a standstill moved the near road (7 m ahead, 620 px) under 0.5 px
UNMEASURED_LOG_SIGMA = 1.0  # a moving step nothing measured the length of: known to a factor of e
# Drift per metre driven, each axis: steps' errors chained as independent leave most poses of the real clips
# outside their 95 % ellipsoids (position 35 / 6 / 42 %, orientation 9 / 0 / 58 % inside on 01 / 06 / 07);
# with these drifts 94 / 100 / 87 % and 100 / 78 / 100 % are inside
DRIFT_FRACTION = 0.02  # metres per metre driven
DRIFT_RAD_PER_M = np.radians(0.02)


def step_covariances(motions: np.ndarray, length_log_sigmas: np.ndarray, standstill: np.ndarray) -> np.ndarray:
    """Covariances (N, 6, 6) of the steps ``motions`` (N, 4, 4; ``T_prev_cur``), each in its current camera's
    frame: along the step the length's (``length_log_sigmas`` (N,): standard deviation of the log length,
    NaN where nothing measured it), across it the direction's, ``ROTATION_SIGMA_RAD`` on each rotation axis;
    a ``standstill`` step (N,) bool is uncertain by ``STANDSTILL_SIGMA_M`` in every direction."""
    motions = np.asarray(motions, dtype=np.float64)
    displacement = np.einsum("nji,nj->ni", motions[:, :3, :3], motions[:, :3, 3])  # in the current frame
    length_m = np.linalg.norm(displacement, axis=1)
    direction = displacement / np.maximum(length_m, 1e-12)[:, None]
    log_sigma = np.where(np.isnan(length_log_sigmas), UNMEASURED_LOG_SIGMA, length_log_sigmas)
    along = (length_m * log_sigma) ** 2
    across = (length_m * DIRECTION_SIGMA_RAD) ** 2 + DIRECTION_FLOOR_M**2
    outer = direction[:, :, None] * direction[:, None, :]
    linear = along[:, None, None] * outer + across[:, None, None] * (np.eye(3) - outer)
    linear[standstill] = STANDSTILL_SIGMA_M**2 * np.eye(3)
    covariances = np.zeros((len(motions), 6, 6))
    covariances[:, :3, :3] = linear
    covariances[:, 3:, 3:] = ROTATION_SIGMA_RAD**2 * np.eye(3)
    return covariances


def adjoint(T: np.ndarray) -> np.ndarray:
    """The adjoint (6, 6) of a transform (4, 4) acting on ``(rho, phi)``: ``T exp(xi) T^-1 = exp(Ad xi)``."""
    R, t = T[:3, :3], T[:3, 3]
    result = np.zeros((6, 6))
    result[:3, :3] = result[3:, 3:] = R
    result[:3, 3:] = skew(t) @ R
    return result


def chained_covariances(motions: np.ndarray, step_covariance: np.ndarray) -> np.ndarray:
    """Covariances (N + 1, 6, 6) of the poses chained from ``motions`` (N, 4, 4) with independent step errors
    of covariances (N, 6, 6), each in its own camera's frame, to first order; the first pose (the world's
    origin) is exact. Chaining ``T exp(xi) M exp(eps) = T M exp(Ad(M^-1) xi + eps)``."""
    covariances = np.zeros((len(motions) + 1, 6, 6))
    for index, (motion, step) in enumerate(zip(motions, step_covariance, strict=True)):
        carried = adjoint(invert_se3(motion))
        covariances[index + 1] = carried @ covariances[index] @ carried.T + step
    return covariances


def drift_covariances(path_m: np.ndarray) -> np.ndarray:
    """The drift's covariances (N, 6, 6) after ``path_m`` (N,) metres driven: ``DRIFT_FRACTION`` of the
    distance on each position axis, ``DRIFT_RAD_PER_M`` of it on each rotation axis (the same in every
    frame)."""
    path_m = np.asarray(path_m, dtype=np.float64)
    covariances = np.zeros((len(path_m), 6, 6))
    covariances[:, :3, :3] = (DRIFT_FRACTION * path_m)[:, None, None] ** 2 * np.eye(3)
    covariances[:, 3:, 3:] = (DRIFT_RAD_PER_M * path_m)[:, None, None] ** 2 * np.eye(3)
    return covariances


def in_parent_axes(rotations: np.ndarray, covariances: np.ndarray) -> np.ndarray:
    """Covariances (N, 6, 6) of right perturbations, each turned by its pose's rotation (N, 3, 3) into the
    parent frame's axes (nav_msgs/Odometry's pose covariance: about the pose, along the parent's axes)."""
    turn = np.zeros((len(rotations), 6, 6))
    turn[:, :3, :3] = turn[:, 3:, 3:] = rotations
    return turn @ covariances @ np.swapaxes(turn, 1, 2)


def odometry_covariances(T_world_cam: np.ndarray, length_log_sigmas: np.ndarray, standstill: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
    """The steps' covariances (N - 1, 6, 6) between the poses ``T_world_cam`` (N, 4, 4) and the poses' (N, 6,
    6): the steps' chained, plus the drift over the path so far; each in its camera's frame (see
    :func:`step_covariances` for the other arguments, one per step)."""
    T_world_cam = np.asarray(T_world_cam, dtype=np.float64)
    motions = relative_motions(T_world_cam)
    steps = step_covariances(motions, np.asarray(length_log_sigmas, dtype=np.float64), np.asarray(standstill, bool))
    path_m = np.concatenate([[0.0], np.cumsum(np.linalg.norm(motions[:, :3, 3], axis=1))])
    return steps, chained_covariances(motions, steps) + drift_covariances(path_m)


def records_covariances(T_world_cam: np.ndarray, records: Sequence[StepRecord]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`odometry_covariances` of a windowed run's poses with its step records (one per step)."""
    log_sigmas = [np.nan if record.log_sigma is None else record.log_sigma for record in records]
    standstill = [record.measured_by == "standstill" for record in records]
    return odometry_covariances(T_world_cam, np.array(log_sigmas, dtype=np.float64), np.array(standstill))
