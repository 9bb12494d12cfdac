"""Print how well the default method's covariances (:mod:`flowvo.odometry.covariance`, written into the
odometry MCAP) cover its errors on the real clips: per clip, the share of moving steps whose translation
error, and of steps whose rotation error, lies inside the step covariance's 95 % ellipsoid, and the share of
poses whose position and orientation errors lie inside the pose covariance's, with the drift and without it
(the steps' errors chained as if independent). A calibrated covariance gives about 95 %.

Usage: python scripts/covariance_calibration.py OUT [DATA_ROOT SEQUENCE ...]
(default: the three real clips, about 30 s)
"""

import subprocess
import sys
from pathlib import Path

import numpy as np
from clip_runs import CLIPS, DEFAULT_CLIPS_ROOT

from flowvo.drive.steps_csv import read_steps_csv
from flowvo.geometry import invert_se3, relative_motions, so3_log
from flowvo.kitti.poses import read_kitti_poses
from flowvo.odometry.covariance import chained_covariances, records_covariances

CHI2_3DOF_95 = 7.815  # the 95 % quantile of a chi-square with 3 degrees of freedom


def share_inside(errors: np.ndarray, covariances: np.ndarray) -> float:
    """The share (%) of 3-vectors (N, 3) inside the 95 % ellipsoids of their covariances (N, 3, 3)."""
    distances = np.einsum("ni,nij,nj->n", errors, np.linalg.inv(covariances), errors)
    return 100.0 * float(np.mean(distances <= CHI2_3DOF_95))


def row(data: Path, clip: str, out: Path) -> str:
    subprocess.run(["flowvo", "-q", "run", "--data", str(data), "--sequence", clip, "--out", str(out), "--force"],
                   check=True, capture_output=True)
    estimate = read_kitti_poses(out / f"{clip}.txt").T_world_cam
    truth = read_kitti_poses(data / "poses" / f"{clip}.txt").T_world_cam[: len(estimate)]
    records = read_steps_csv(out / f"{clip}_steps.csv")
    steps, poses = records_covariances(estimate, records)
    motions = relative_motions(estimate)
    step_error = invert_se3(motions) @ relative_motions(truth)  # true = estimate exp(xi)
    moving = np.array([record.measured_by != "standstill" for record in records])
    without_drift = chained_covariances(motions, steps)
    position_error = np.einsum("nji,nj->ni", estimate[:, :3, :3], truth[:, :3, 3] - estimate[:, :3, 3])[1:]
    orientation_error = so3_log(np.einsum("nji,njk->nik", estimate[:, :3, :3], truth[:, :3, :3]))[1:]
    cells = [share_inside(step_error[moving, :3, 3], steps[moving, :3, :3]),
             share_inside(so3_log(step_error[:, :3, :3]), steps[:, 3:, 3:]),
             share_inside(position_error, poses[1:, :3, :3]), share_inside(position_error, without_drift[1:, :3, :3]),
             share_inside(orientation_error, poses[1:, 3:, 3:]),
             share_inside(orientation_error, without_drift[1:, 3:, 3:])]
    return f"| {data.name} {clip} | {len(records)} | " + " | ".join(f"{cell:.0f}" for cell in cells) + " |"


def main(out: Path, drives: list[tuple[Path, str]]) -> None:
    print("| drive | steps | step translation | step rotation | pose position | (no drift) | pose orientation "
          "| (no drift) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for data, clip in drives:
        print(row(data, clip, out / f"{data.name}_{clip}"), flush=True)
    print("cells: % of steps or poses whose error lies inside the covariance's 95 % ellipsoid")


if __name__ == "__main__":
    arguments = sys.argv[2:]
    main(Path(sys.argv[1]), [(Path(arguments[i]), arguments[i + 1]) for i in range(0, len(arguments), 2)]
         if arguments else [(DEFAULT_CLIPS_ROOT, clip) for clip in CLIPS])
