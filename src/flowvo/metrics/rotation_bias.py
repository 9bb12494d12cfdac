"""The run's step rotations against the truth's: the mean error each step rotates by about the camera's axes (a
bias adds up along a drive where noise averages out), the slope of the run's yaw against the truth's (under 1:
turns read short), how far the run's turns read against the truth's at each speed, and the run with that mean error
taken off every step or with its yaw rescaled, to score what each costs.

Poses are ``T_world_cam`` (N, 4, 4), camera-to-world, KITTI's camera frame (x right, y down, z forward), metres;
the truth and the run hold the same N frames. A step's rotation is that of ``T_prev_cur``
(:func:`flowvo.geometry.relative_motions`) as an axis-angle vector (radians): about x a pitch (positive: nose up),
about y a yaw (positive: to the right), about z a roll (positive: right side down). A step's rotation error is the
axis-angle vector of ``R_true^T R_run``, the run's step rotation after the truth's. Steps on which the truth moved
less than ``min_step_m`` are left out: a car standing still has no rotation of its own to measure.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flowvo.geometry import relative_motions, so3_exp, so3_log

MIN_ROTATION_STEP_M = 0.05  # shorter true steps are standstills (the default method holds their rotation)
MIN_TURN_RAD = np.radians(0.2)  # without a step turning this much the yaw slope is not read
SPEED_BAND_EDGES_MPS = (0.0, 3.0, 6.0, 9.0, 13.0, 20.0, 40.0)  # the turns' reading by speed: walking pace, town, road,
# motorway


@dataclass(frozen=True)
class RotationBias:
    """The mean rotation error per step over ``steps`` moving steps, (3,) radians about the camera's x, y, z axes
    (pitch, yaw, roll), and ``yaw_slope``, the slope of the run's yaw per step against the truth's over those steps
    (a least-squares line, so that a constant error does not move it; the turns carry it), NaN where none of them
    turned ``MIN_TURN_RAD`` or more (``turning_steps`` did) or fewer than three moved."""

    mean_error_rad: np.ndarray
    steps: int
    yaw_slope: float
    turning_steps: int

    @property
    def mean_error_mdeg(self) -> np.ndarray:
        """The mean rotation error per step (3,), millidegrees about x, y, z (as reported)."""
        return np.degrees(self.mean_error_rad) * 1000.0


@dataclass(frozen=True)
class TurnReading:
    """The turns of the steps whose true speed lies in ``low_mps``..``high_mps``: how many steps turned
    ``MIN_TURN_RAD`` or more (``steps``), by how much in all (``true_turn_deg``, each step's yaw taken unsigned),
    and the run's yaw on those steps, each signed as the truth's turn, over that sum (``read``: under 1 the turns read
    short, whichever way they go)."""

    low_mps: float
    high_mps: float
    steps: int
    true_turn_deg: float
    read: float


def moving_steps(T_gt: np.ndarray, min_step_m: float = MIN_ROTATION_STEP_M) -> np.ndarray:
    """Which steps (N-1,) bool the truth moved at least ``min_step_m`` on."""
    return np.linalg.norm(np.diff(T_gt[:, :3, 3], axis=0), axis=1) >= min_step_m


def _check_same_frames(T_gt: np.ndarray, T_pred: np.ndarray) -> None:
    """ValueError unless the truth and the run are both (N, 4, 4) poses of the same N >= 2 frames."""
    if T_gt.shape != T_pred.shape or T_gt.ndim != 3 or T_gt.shape[1:] != (4, 4) or len(T_gt) < 2:
        raise ValueError(f"the truth and the run must both be (N, 4, 4) poses of the same N >= 2 frames, got "
                         f"{T_gt.shape} and {T_pred.shape}")


def step_rotation_vectors(T_world_cam: np.ndarray) -> np.ndarray:
    """Each step's rotation as an axis-angle vector (N-1, 3), radians: x pitch, y yaw, z roll (module docstring)."""
    return so3_log(relative_motions(T_world_cam)[:, :3, :3])


def step_rotation_errors(T_gt: np.ndarray, T_pred: np.ndarray) -> np.ndarray:
    """Each step's rotation error (N-1, 3), radians (module docstring)."""
    _check_same_frames(T_gt, T_pred)
    R_true, R_run = relative_motions(T_gt)[:, :3, :3], relative_motions(T_pred)[:, :3, :3]
    return so3_log(np.swapaxes(R_true, 1, 2) @ R_run)


def rotation_bias(T_gt: np.ndarray, T_pred: np.ndarray, min_step_m: float = MIN_ROTATION_STEP_M) -> RotationBias:
    """The run's :class:`RotationBias` against the truth over the steps the truth moved ``min_step_m`` or more
    (a zero mean and a NaN slope where it never did)."""
    errors = step_rotation_errors(T_gt, T_pred)
    moving = moving_steps(T_gt, min_step_m)
    true_yaw, run_yaw = step_rotation_vectors(T_gt)[:, 1], step_rotation_vectors(T_pred)[:, 1]
    turning = moving & (np.abs(true_yaw) >= MIN_TURN_RAD)
    slope = float(np.polyfit(true_yaw[moving], run_yaw[moving], 1)[0]) if turning.any() and moving.sum() > 2 \
        else float("nan")
    mean = errors[moving].mean(axis=0) if moving.any() else np.zeros(3)
    return RotationBias(mean, int(moving.sum()), slope, int(turning.sum()))


def turn_reading_by_speed(T_gt: np.ndarray, T_pred: np.ndarray, times_s: np.ndarray,
                          edges_mps: tuple[float, ...] = SPEED_BAND_EDGES_MPS) -> list[TurnReading]:
    """The run's turns against the truth's in each band of true speed between consecutive ``edges_mps`` (m/s),
    :class:`TurnReading`; bands without a step turning ``MIN_TURN_RAD`` or more are left out. ``times_s`` (N,): the
    frames' times, seconds. A focal length off would read every band alike; a reading that changes with the speed
    comes from elsewhere."""
    _check_same_frames(T_gt, T_pred)
    times_s = np.asarray(times_s, dtype=float)
    if times_s.shape != (len(T_gt),) or not np.all(np.diff(times_s) > 0):
        raise ValueError(f"one increasing time per frame expected: {len(T_gt)} frames, {times_s.shape} times")
    true_yaw, run_yaw = step_rotation_vectors(T_gt)[:, 1], step_rotation_vectors(T_pred)[:, 1]
    speed_mps = np.linalg.norm(np.diff(T_gt[:, :3, 3], axis=0), axis=1) / np.diff(times_s)
    turning = moving_steps(T_gt) & (np.abs(true_yaw) >= MIN_TURN_RAD)
    readings = []
    for low, high in zip(edges_mps[:-1], edges_mps[1:], strict=True):
        inside = turning & (speed_mps >= low) & (speed_mps < high)
        if inside.any():
            turned = float(np.abs(true_yaw[inside]).sum())
            read = float((run_yaw[inside] * np.sign(true_yaw[inside])).sum()) / turned
            readings.append(TurnReading(low, high, int(inside.sum()), float(np.degrees(turned)), read))
    return readings


def with_rotation_bias_removed(T_gt: np.ndarray, T_pred: np.ndarray, mean_error_rad: np.ndarray,
                               min_step_m: float = MIN_ROTATION_STEP_M) -> np.ndarray:
    """The run (N, 4, 4) with ``mean_error_rad`` (3,) taken off the rotation of every step the truth moved
    ``min_step_m`` or more on (each step's rotation ``R_run exp(-mean_error_rad)``,
    :func:`with_step_rotations_changed`)."""
    moving = moving_steps(T_gt, min_step_m)
    undo = so3_exp(-np.asarray(mean_error_rad, dtype=float))
    return with_step_rotations_changed(T_pred, np.where(moving[:, None, None], undo, np.eye(3)))


def with_yaw_scaled(T_pred: np.ndarray, gain: float) -> np.ndarray:
    """The run (N, 4, 4) with every step's yaw, the y component of its rotation's axis-angle vector, times ``gain``
    (:func:`with_step_rotations_changed`): with the inverse of :attr:`RotationBias.yaw_slope`, its turns at the
    truth's size."""
    rotation_vectors = step_rotation_vectors(T_pred)
    scaled = rotation_vectors * [1.0, gain, 1.0]
    return with_step_rotations_changed(T_pred, np.swapaxes(so3_exp(rotation_vectors), 1, 2) @ so3_exp(scaled))


def with_step_rotations_changed(T_pred: np.ndarray, changes: np.ndarray) -> np.ndarray:
    """The run (N, 4, 4) with each step's rotation ``R_run`` turned into ``R_run @ changes[k]`` ((N-1, 3, 3)
    rotations), from its first pose, each step's translation in the camera frame of its start its own. Built as the
    run's orientations turned by a correction chained over the steps, so that where every change is the identity the
    poses stay the run's."""
    R_step = so3_exp(step_rotation_vectors(T_pred))  # orthonormal: chained over thousands of steps,
    # the run's own (orthonormal to about 4e-7 in a KITTI file) would shrink the rotations
    poses = T_pred.copy()
    correction = np.eye(3)  # each fixed orientation is the run's times this
    for k in range(len(R_step)):
        in_world = poses[k, :3, :3] @ np.linalg.inv(T_pred[k, :3, :3])  # the correction turning the world's steps
        poses[k + 1, :3, 3] = poses[k, :3, 3] + in_world @ (T_pred[k + 1, :3, 3] - T_pred[k, :3, 3])
        correction = R_step[k].T @ correction @ R_step[k] @ changes[k]
        poses[k + 1, :3, :3] = T_pred[k + 1, :3, :3] @ correction
    return poses
