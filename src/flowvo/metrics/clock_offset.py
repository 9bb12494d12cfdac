"""The truth's clock against the images': by how many frames the run's step rotations lead the truth's, and the run
read at the truth's times.

A truth whose pose k belongs to a moment ``d`` frames before image k was taken (``d > 0``: the images lead) gives the
run's step k the truth's rotation from ``k + d`` to ``k + 1 + d``. To first order its rotation error is then ``d``
times the change of the truth's step rotation there, ``(r[k+1] - r[k-1]) / 2`` (axis-angle vectors, radians). ``d``
is the least-squares slope of the errors on those changes, pooled over the camera's three axes, each axis's mean
error (its bias) taken out first: turns carry it, and so does a car's vibration, which changes its pitch and roll from
step to step on straight roads too. Reading the run at frame ``k - d`` then takes the offset back out of the score.

Poses are ``T_world_cam`` (N, 4, 4), camera-to-world, metres, of the same N frames; steps and their rotation errors
as in :mod:`flowvo.metrics.rotation_bias`. Only the truth's clock is in question: the method never sees the truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flowvo.geometry import so3_exp, so3_log
from flowvo.metrics.rotation_bias import (
    MIN_ROTATION_STEP_M,
    moving_steps,
    step_rotation_errors,
    step_rotation_vectors,
)


@dataclass(frozen=True)
class ClockOffset:
    """The run's lead over the truth, ``frames`` (positive: each image was taken that many frames after its true
    pose's moment; NaN where it cannot be read) with its ``standard_error`` (frames; the steps' errors taken as
    independent), from ``steps`` steps, and the share of their rotation errors' variance (about each axis's mean) that
    the lead explains, 0..1. A lead within two standard errors of zero is not told apart from none."""

    frames: float
    standard_error: float
    steps: int
    explained: float


def clock_offset(T_gt: np.ndarray, T_pred: np.ndarray, min_step_m: float = MIN_ROTATION_STEP_M) -> ClockOffset:
    """The run's :class:`ClockOffset` against the truth over the steps that moved ``min_step_m`` or more with moving
    neighbours on both sides (NaN where fewer than three did, or where the truth's rotation never changed)."""
    errors = step_rotation_errors(T_gt, T_pred)
    true_rotations = step_rotation_vectors(T_gt)
    moving = moving_steps(T_gt, min_step_m)
    inner = moving[1:-1] & moving[:-2] & moving[2:]  # steps 1..N-3 with both neighbours moving
    if inner.sum() < 3:
        return ClockOffset(float("nan"), float("nan"), int(inner.sum()), float("nan"))
    change = (true_rotations[2:] - true_rotations[:-2])[inner] / 2.0
    error = errors[1:-1][inner]
    change -= change.mean(axis=0)
    error -= error.mean(axis=0)
    spread = float((change * change).sum())
    if spread == 0.0:
        return ClockOffset(float("nan"), float("nan"), int(inner.sum()), float("nan"))
    frames = float((change * error).sum()) / spread
    total, residual = float((error * error).sum()), float(((error - frames * change) ** 2).sum())
    degrees_of_freedom = error.size - 4  # three axes' means and the lead
    return ClockOffset(frames, float(np.sqrt(residual / degrees_of_freedom / spread)), int(inner.sum()),
                       1.0 - residual / total if total > 0 else 0.0)


def read_at_frames(T_world_cam: np.ndarray, shift_frames: float) -> np.ndarray:
    """The poses (N, 4, 4) at frames ``k + shift_frames`` for k = 0..N-1: each between its two neighbouring poses
    (rotation along the geodesic, position along the straight line), beyond the ends along the first or last step."""
    n = len(T_world_cam)
    if n < 2:
        raise ValueError("poses of at least two frames are needed to read them between frames")
    at = np.arange(n) + shift_frames
    base = np.clip(np.floor(at).astype(np.int64), 0, n - 2)
    fraction = at - base
    start, end = T_world_cam[base], T_world_cam[base + 1]
    step_rotation = so3_log(np.swapaxes(start[:, :3, :3], 1, 2) @ end[:, :3, :3])
    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, :3, :3] = start[:, :3, :3] @ so3_exp(step_rotation * fraction[:, None])
    poses[:, :3, 3] = start[:, :3, 3] + fraction[:, None] * (end[:, :3, 3] - start[:, :3, 3])
    return poses


def with_clock_offset_removed(T_pred: np.ndarray, offset: ClockOffset) -> np.ndarray:
    """The run (N, 4, 4) read at the truth's times, frame ``k - offset.frames`` for frame k (the run as it is where
    the offset is NaN)."""
    return T_pred if np.isnan(offset.frames) else read_at_frames(T_pred, -offset.frames)
