"""``flowvo.evaluate``: a trajectory scored against ground truth, by the code of ``flowvo eval`` and ``flowvo run``
(:func:`flowvo.report.evaluation.evaluate`: the KITTI odometry metric, ATE, one-frame RPE)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from flowvo.errors import FlowvoError
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M
from flowvo.report.evaluation import EVALUATION_FILES
from flowvo.report.evaluation import Evaluation as _Evaluation
from flowvo.trajectory import Trajectory as PoseTable


class Evaluation:
    """The scores of one trajectory: ``t_err_percent`` (KITTI translation error, % of the sub-path length; None
    when the path is shorter than every sub-path), ``r_err_deg_per_m`` (degrees per metre), ``ate_rmse_m``
    (metres), and every number in ``metrics`` (what ``metrics.json`` holds, with units)."""

    def __init__(self, evaluation: _Evaluation) -> None:
        self.evaluation = evaluation
        self.metrics: dict = evaluation.metrics

    @property
    def t_err_percent(self) -> float | None:
        return self.metrics["t_err_percent"]

    @property
    def r_err_deg_per_m(self) -> float | None:
        return self.metrics["r_err_deg_per_m"]

    @property
    def ate_rmse_m(self) -> float:
        return self.metrics["ate_rmse_m"]

    def save(self, folder: str | Path, *, force: bool = False) -> list[Path]:
        """Write ``metrics.json``, ``per_frame_errors.csv`` and the plots into ``folder``, as ``flowvo eval`` does (an
        earlier evaluation there is replaced only with ``force``); returns the files."""
        from flowvo.io.outputs import prepare_output_dir
        from flowvo.report.evaluation import save_evaluation

        return save_evaluation(self.evaluation, prepare_output_dir(folder, EVALUATION_FILES, force, what="folder"))

    def __repr__(self) -> str:
        t_err = "n/a" if self.t_err_percent is None else f"{self.t_err_percent:.3f} %"
        r_err = "n/a" if self.r_err_deg_per_m is None else f"{self.r_err_deg_per_m:.5f} deg/m"
        return f"Evaluation(t_err={t_err}, r_err={r_err}, ate_rmse={self.ate_rmse_m:.3f} m)"


def pose_table(poses: Any, what: str) -> PoseTable:
    """Poses as frames and ``T_world_cam``: a KITTI pose file (path), a :class:`flowvo.Trajectory`, a
    :class:`flowvo.trajectory.Trajectory`, or an array of N poses, (N, 4, 4), (N, 3, 4) or (N, 12) (KITTI's
    row-major [R | t]), frame i at row i."""
    if isinstance(poses, PoseTable):
        return poses
    if callable(getattr(poses, "pose_table", None)):  # a flowvo.Trajectory (its module imports this one)
        return poses.pose_table()
    if isinstance(poses, str | Path):
        from flowvo.kitti.poses import read_kitti_poses

        return read_kitti_poses(poses)
    array = np.asarray(poses, dtype=np.float64)
    if array.ndim == 2 and array.shape[1] == 12:
        array = array.reshape(-1, 3, 4)
    if array.ndim != 3 or array.shape[1:] not in ((3, 4), (4, 4)) or not np.all(np.isfinite(array)):
        raise FlowvoError(f"{what}: expected a pose file, a trajectory or finite poses (N, 4, 4), (N, 3, 4) or "
                          f"(N, 12), got shape {array.shape}")
    full = np.tile(np.eye(4), (len(array), 1, 1))
    full[:, :3, :] = array[:, :3, :]
    return PoseTable.from_poses(full)


def evaluate(gt: Any, trajectory: Any, lengths: tuple[float, ...] = SEGMENT_LENGTHS_M,
             alignment: str = "none") -> Evaluation:
    """Score ``trajectory`` against the ground truth ``gt`` (each: a KITTI pose file, a :class:`flowvo.Trajectory`
    or an array of poses, see :func:`pose_table`): the KITTI metric on sub-paths of ``lengths`` metres (the
    devkit's 100..800 m by default; a short drive needs shorter ones), ATE after ``alignment`` ("none", "6dof",
    "7dof") and one-frame RPE. A trajectory of frames 0..N-1 is scored against the ground truth's first N
    frames, as ``flowvo run`` scores a drive cut short with ``--max-frames``."""
    from flowvo.report.evaluation import evaluate as evaluate_poses

    if alignment not in ("none", "6dof", "7dof"):
        raise FlowvoError(f"alignment must be none, 6dof or 7dof, got {alignment!r}")
    lengths_m = tuple(sorted({float(length) for length in np.atleast_1d(lengths)}))
    if not lengths_m or min(lengths_m) <= 0 or not all(np.isfinite(lengths_m)):
        raise FlowvoError(f"lengths must be positive metres, got {lengths!r}")
    gt_poses, predicted = pose_table(gt, "gt"), pose_table(trajectory, "trajectory")
    if predicted.is_complete and len(predicted) < len(gt_poses) and gt_poses.is_complete:
        gt_poses = gt_poses.subset(np.arange(len(predicted)))
    return Evaluation(evaluate_poses(gt_poses, predicted, alignment, lengths_m))
