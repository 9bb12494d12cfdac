"""The KITTI odometry metric, a faithful port of the official devkit ``evaluate_odometry.cpp``.

For every 10th first frame and each sub-path length L in 100..800 m, the last frame is the first whose
ground-truth path distance exceeds ``dist[first] + L``; the segment error is
``E = inv(inv(P[f]) P[l]) (inv(G[f]) G[l])``, its rotation error ``acos(clamp((trace(R_E) - 1) / 2))`` and
translation error ``||t_E||``, both divided by L; the segment speed is ``L / (0.1 * (l - f + 1))`` m/s.
Averages run over all segments (of one sequence, or of several sequences pooled).

Arithmetic as the compiled devkit: poses and inverses in double (a general inverse, not R^T); path
distances, the error's trace and ``acos``, the translation norm, the division by L, the sums and the
averages in float32 (the C++ ``float`` variables). This reproduces the devkit's printed numbers to ~1e-10
relative; it also means a rotation error below ~3e-4 rad per segment is rounded (float32 ``acos`` near
1), which is why :mod:`flowvo.metrics.trajectory_errors` computes its per-frame angles differently.

Units: translation error as a fraction (x100 for %), rotation error in rad/m (converted in summaries to
deg/m and deg/100m, always named so). Missing predicted frames: a segment is skipped when its first or
last frame has no prediction; distances always come from the complete ground truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flowvo.trajectory import Trajectory

SEGMENT_LENGTHS_M = (100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0)
STEP_FRAMES = 10
FRAME_PERIOD_S = 0.1
SPEED_BINS_MPS = tuple(float(s) for s in range(2, 25, 2))
SPEED_BIN_HALF_WIDTH_MPS = 2.0
MIN_SAMPLES_PER_BIN = 3


@dataclass(frozen=True)
class SegmentErrors:
    """Per-segment errors (M,) each: first frame, rotation error rad/m, translation error (fraction),
    segment length m, speed m/s."""

    first_frame: np.ndarray
    r_err_rad_per_m: np.ndarray
    t_err: np.ndarray
    length_m: np.ndarray
    speed_mps: np.ndarray

    def __len__(self) -> int:
        return len(self.first_frame)

    @staticmethod
    def concatenate(parts: list[SegmentErrors]) -> SegmentErrors:
        """Pool the segments of several sequences (for the multi-sequence average)."""
        fields = ("first_frame", "r_err_rad_per_m", "t_err", "length_m", "speed_mps")
        return SegmentErrors(*(np.concatenate([getattr(p, f) for p in parts]) for f in fields))


def trajectory_distances(positions_m: np.ndarray) -> np.ndarray:
    """Cumulative path length (N,) in metres along positions (N, 3), starting at 0, float32 as the devkit
    computes it: each step's double difference cast to float32, its length and the running sum in float32."""
    d = (positions_m[:-1] - positions_m[1:]).astype(np.float32)
    steps = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])
    return np.concatenate([np.zeros(1, np.float32), steps]).cumsum(dtype=np.float32)


def last_frame_from_segment_length(distances_m: np.ndarray, first: int, length_m: float) -> int:
    """Index of the first frame whose distance exceeds ``distances_m[first] + length_m`` (float32 sum), or -1."""
    limit = np.float32(distances_m[first]) + np.float32(length_m)
    beyond = np.flatnonzero(distances_m[first:] > limit)
    return int(first + beyond[0]) if len(beyond) else -1


def rotation_error_rad(pose_error: np.ndarray) -> np.ndarray:
    """Rotation angle (rad, float32) of error transforms (..., 4, 4), as the devkit computes it:
    ``acos(clamp(0.5 * (a + b + c - 1)))`` with the diagonal a, b, c and their sum in float32."""
    diagonal = np.diagonal(pose_error[..., :3, :3], axis1=-2, axis2=-1).astype(np.float32)
    trace = diagonal[..., 0] + diagonal[..., 1] + diagonal[..., 2]
    d = (0.5 * (trace.astype(np.float64) - 1.0)).astype(np.float32)
    return np.arccos(np.clip(d, np.float32(-1.0), np.float32(1.0)))


def translation_error_m(pose_error: np.ndarray) -> np.ndarray:
    """Translation norm (m, float32) of error transforms (..., 4, 4), as the devkit computes it."""
    t = pose_error[..., :3, 3].astype(np.float32)
    return np.sqrt(t[..., 0] * t[..., 0] + t[..., 1] * t[..., 1] + t[..., 2] * t[..., 2])


def mean_float32(values: np.ndarray) -> float:
    """The devkit's average: a float32 running sum in order, divided by the count in float32."""
    total = np.cumsum(np.asarray(values, dtype=np.float32), dtype=np.float32)[-1]
    return float(total / np.float32(len(values)))


def sequence_segment_errors(gt: Trajectory, pred: Trajectory,
                            lengths_m: tuple[float, ...] = SEGMENT_LENGTHS_M) -> SegmentErrors:
    """All devkit segment errors of one sequence. ``gt`` must be complete (frames 0..N-1).

    ``lengths_m``: the sub-path lengths (the devkit's 100..800 m by default; shorter ones score short
    drives the same way, and are reported as such).

    Poses and their inverses in double with a general inverse (as the devkit's ``Matrix::inv``, not R^T);
    distances, error norms and the division by the length in float32, as the devkit's ``float`` variables.
    """
    if not gt.is_complete:
        raise ValueError("ground truth must contain every frame")
    distances = trajectory_distances(gt.positions)
    n_frames = len(gt)
    pred_index = np.full(n_frames, -1)
    present = pred.frame_ids < n_frames
    pred_index[pred.frame_ids[present]] = np.flatnonzero(present)
    firsts, lasts, lengths = [], [], []
    for first in range(0, n_frames, STEP_FRAMES):
        for length in lengths_m:
            last = last_frame_from_segment_length(distances, first, length)
            if last == -1 or pred_index[first] < 0 or pred_index[last] < 0:
                continue
            firsts.append(first)
            lasts.append(last)
            lengths.append(length)
    first_idx = np.asarray(firsts, dtype=np.int64)
    last_idx = np.asarray(lasts, dtype=np.int64)
    segment_m = np.asarray(lengths, dtype=np.float32)
    G, P = gt.T_world_cam, pred.T_world_cam
    delta_gt = np.linalg.inv(G[first_idx]) @ G[last_idx]
    delta_pred = np.linalg.inv(P[pred_index[first_idx]]) @ P[pred_index[last_idx]]
    pose_error = np.linalg.inv(delta_pred) @ delta_gt
    frames = (last_idx - first_idx + 1).astype(np.float32)
    return SegmentErrors(
        first_frame=first_idx,
        r_err_rad_per_m=rotation_error_rad(pose_error) / segment_m,
        t_err=translation_error_m(pose_error) / segment_m,
        length_m=segment_m,
        speed_mps=(segment_m / (FRAME_PERIOD_S * frames.astype(np.float64))).astype(np.float32),
    )


def _binned(errors: SegmentErrors, mask_per_bin: list[np.ndarray], centres: tuple[float, ...], key: str) -> list:
    rows = []
    for centre, mask in zip(centres, mask_per_bin, strict=True):
        count = int(mask.sum())
        if count < MIN_SAMPLES_PER_BIN:
            continue
        r = mean_float32(errors.r_err_rad_per_m[mask])
        rows.append(
            {
                key: centre,
                "t_err_percent": 100.0 * mean_float32(errors.t_err[mask]),
                "r_err_deg_per_m": float(np.degrees(r)),
                "r_err_deg_per_100m": 100.0 * float(np.degrees(r)),
                "segments": count,
            }
        )
    return rows


def summarize(errors: SegmentErrors, lengths_m: tuple[float, ...] = SEGMENT_LENGTHS_M) -> dict:
    """Average errors and the per-length and per-speed curves, with units in every key; ``lengths_m``
    are the sub-path lengths the segments were cut at (recorded in the result)."""
    if len(errors) == 0:
        raise ValueError(f"no segment: the trajectory is shorter than {min(lengths_m):g} m or lacks frames")
    r_mean = mean_float32(errors.r_err_rad_per_m)
    per_length = _binned(errors, [np.abs(errors.length_m - L) < 1.0 for L in lengths_m], lengths_m, "length_m")
    per_speed = _binned(
        errors,
        [np.abs(errors.speed_mps - s) < SPEED_BIN_HALF_WIDTH_MPS for s in SPEED_BINS_MPS],
        SPEED_BINS_MPS,
        "speed_mps",
    )
    return {
        "t_err_percent": 100.0 * mean_float32(errors.t_err),
        "r_err_deg_per_m": float(np.degrees(r_mean)),
        "r_err_deg_per_100m": 100.0 * float(np.degrees(r_mean)),
        "segments": len(errors),
        "segment_lengths_m": [float(L) for L in lengths_m],
        "per_length": per_length,
        "per_speed": per_speed,
    }
