"""Print how a trajectory's rotation drifts against the ground truth, per camera axis: whether r_err is noise
(errors of either sign that average out) or a drift of the same sign step after step.

Per step, the error rotation ``R_gt^T R_pred`` of the step's motion (camera frame, x right, y down, z forward)
as an axis-angle vector (:func:`flowvo.metrics.rotation_bias.step_rotation_errors`); its mean over the steps (the
drift a step), its rms, and the drift over the path in degrees per 100 m (the steps' errors summed about each axis
over the truth's path length). Last, the orientation error of the poses themselves (angle of ``R_gt^T R_pred``,
world = first camera), rms over the frames and at the last one. Degrees throughout. ``drive_diagnostic.py`` scores
what the mean error costs (the run with it removed) and the run's yaw against the truth's.

Usage: python scripts/rotation_drift.py GT_POSES PRED_POSES [PRED_POSES ...]   (KITTI pose files, the same
frames; e.g. a held-out sequence's truth and ``flowvo run`` outputs of several methods)
"""

import sys
from pathlib import Path

import numpy as np

from flowvo.geometry import so3_log
from flowvo.kitti.poses import read_kitti_poses
from flowvo.metrics.kitti_odometry import trajectory_distances
from flowvo.metrics.rotation_bias import step_rotation_errors


def pose_rotation_errors_deg(T_gt: np.ndarray, T_pred: np.ndarray) -> np.ndarray:
    """Angles (N,), degrees, between the truth's and the prediction's orientations, frame by frame."""
    return np.degrees(np.linalg.norm(so3_log(np.swapaxes(T_gt[:, :3, :3], -1, -2) @ T_pred[:, :3, :3]), axis=-1))


def main(gt_path: Path, pred_paths: list[Path]) -> None:
    T_gt = read_kitti_poses(gt_path).T_world_cam
    path_m = float(trajectory_distances(T_gt[:, :3, 3])[-1])
    print(f"truth: {gt_path} ({len(T_gt)} frames, {path_m:.1f} m); axes of the camera: x right, y down, z forward")
    print("| prediction | mean a step x / y / z | rms a step x / y / z | drift deg/100 m x / y / z "
          "| orientation error rms / last |")
    print("| --- | --- | --- | --- | --- |")
    for pred_path in pred_paths:
        T_pred = read_kitti_poses(pred_path).T_world_cam
        if len(T_pred) != len(T_gt):
            raise SystemExit(f"{pred_path}: {len(T_pred)} poses, the truth has {len(T_gt)}")
        steps = np.degrees(step_rotation_errors(T_gt, T_pred))
        poses = pose_rotation_errors_deg(T_gt, T_pred)
        mean, rms, drift = steps.mean(0), np.sqrt((steps ** 2).mean(0)), 100.0 * steps.sum(0) / path_m
        print(f"| {pred_path} | " + " / ".join(f"{v:+.4f}" for v in mean) + " | "
              + " / ".join(f"{v:.4f}" for v in rms) + " | " + " / ".join(f"{v:+.3f}" for v in drift)
              + f" | {np.sqrt((poses ** 2).mean()):.3f} / {poses[-1]:.3f} |")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit("usage: python scripts/rotation_drift.py GT_POSES PRED_POSES [PRED_POSES ...]")
    main(Path(sys.argv[1]), [Path(p) for p in sys.argv[2:]])
