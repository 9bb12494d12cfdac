"""Absolute trajectory error (ATE) with optional alignment, and relative pose error (RPE).

Alignment modes: ``none`` expresses both trajectories relative to their first common pose (no fitting),
``6dof`` fits the rigid transform, ``7dof`` the similarity transform with scale (Umeyama 1991), both
least squares over the positions of the common frames.
"""

from __future__ import annotations

import numpy as np

from flowvo.geometry import invert_se3, relative_motions, rotation_angle_between_rad
from flowvo.trajectory import Trajectory, common_frames

ALIGNMENTS = ("none", "6dof", "7dof")


def umeyama_alignment(source: np.ndarray, target: np.ndarray, with_scale: bool) -> tuple[np.ndarray, np.ndarray, float]:
    """Rotation R, translation t and scale s minimising ``||target - (s R source + t)||^2``; points (N, 3)."""
    mu_s, mu_t = source.mean(0), target.mean(0)
    src, tgt = source - mu_s, target - mu_t
    covariance = tgt.T @ src / len(source)
    U, singular, Vt = np.linalg.svd(covariance)
    S = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        S[2, 2] = -1.0
    R = U @ S @ Vt
    variance = (src**2).sum() / len(source)
    scale = float(np.trace(np.diag(singular) @ S) / variance) if with_scale and variance > 0 else 1.0
    t = mu_t - scale * R @ mu_s
    return R, t, scale


def aligned_positions(gt: Trajectory, pred: Trajectory, alignment: str) -> tuple[np.ndarray, np.ndarray]:
    """Positions (M, 3) of the common frames: ground truth and the aligned prediction."""
    if alignment not in ALIGNMENTS:
        raise ValueError(f"alignment must be one of {ALIGNMENTS}, got {alignment!r}")
    gt_c, pred_c = common_frames(gt, pred)
    if len(gt_c) == 0:
        raise ValueError("ground truth and prediction share no frame")
    if alignment == "none":
        anchor = gt_c.T_world_cam[0] @ invert_se3(pred_c.T_world_cam[0])
        moved = anchor @ pred_c.T_world_cam
        return gt_c.positions, moved[:, :3, 3]
    R, t, s = umeyama_alignment(pred_c.positions, gt_c.positions, with_scale=alignment == "7dof")
    return gt_c.positions, (s * (R @ pred_c.positions.T)).T + t


def ate_rmse_m(gt: Trajectory, pred: Trajectory, alignment: str = "none") -> float:
    """Root-mean-square position error (m) after the given alignment."""
    gt_pos, pred_pos = aligned_positions(gt, pred, alignment)
    return float(np.sqrt(np.mean(np.sum((gt_pos - pred_pos) ** 2, axis=1))))


def per_frame_errors(gt: Trajectory, pred: Trajectory) -> dict[str, np.ndarray]:
    """Relative pose error between consecutive common frames: translation (m) and rotation (deg) each.

    With the motions ``D_gt``, ``D_pred`` of a step, the error ``D_pred^-1 D_gt`` has translation norm
    ``||t_gt - t_pred||`` and the rotation angle between ``R_pred`` and ``R_gt``; both are computed so
    that identical motions give exactly 0 (no rounding floor), as evo reports.
    """
    gt_c, pred_c = common_frames(gt, pred)
    delta_gt = relative_motions(gt_c.T_world_cam)
    delta_pred = relative_motions(pred_c.T_world_cam)
    return {
        "frame_id": gt_c.frame_ids[1:],
        "translation_error_m": np.linalg.norm(delta_gt[:, :3, 3] - delta_pred[:, :3, 3], axis=-1),
        "rotation_error_deg": np.degrees(rotation_angle_between_rad(delta_pred[:, :3, :3], delta_gt[:, :3, :3])),
    }


def rpe(gt: Trajectory, pred: Trajectory) -> dict[str, float]:
    """RPE over one-frame steps: RMSE of translation (m) and rotation (deg)."""
    errors = per_frame_errors(gt, pred)
    return {
        "rpe_trans_rmse_m": float(np.sqrt(np.mean(errors["translation_error_m"] ** 2))),
        "rpe_rot_rmse_deg": float(np.sqrt(np.mean(errors["rotation_error_deg"] ** 2))),
    }
