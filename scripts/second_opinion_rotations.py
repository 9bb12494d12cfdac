"""How much of a run's rotation error against a real truth the images share: the run's rotations against a second
opinion's, an independent two-view pipeline's, on the truth's path.

The second opinion shares nothing with flowvo's method but the frames and the camera: Shi-Tomasi corners (1500 a
frame) tracked by pyramidal Lucas-Kanade (21 px windows, checked forward-backward within 0.1 px), MAGSAC's essential
matrix (of its two rotations the smaller), then the rotation and direction refitted to its inliers by least squares on
the Sampson error (Cauchy, 0.1 px), frames area-resized to ``--width``. Steps whose tracks moved less than 0.3 px in
the median are standstills (no rotation). Both runs are put on the truth's path
(:func:`flowvo.metrics.error_split.on_true_path`: its positions, each run's orientations) and scored with the KITTI
metric: each against the truth, and the run against the second opinion. Where two independent pipelines agree far
better than either agrees with the truth, that part of the error is common to the images: the truth's attitude, its
clock, the calibration, or what no two-view fit separates, not the method's. Per axis, the correlation of the two
pipelines' step rotation errors against the truth.

Usage: python scripts/second_opinion_rotations.py ROOT SEQUENCE RUN.txt [--lengths 100 200 ...] [--width 620]
(a KITTI-layout ROOT whose ``poses/SEQUENCE.txt`` holds the truth; RUN.txt a run's poses of the same frames. About
40 frames a second on two cores.)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np
from scipy.optimize import least_squares

from flowvo.camera import CameraIntrinsics
from flowvo.errors import FlowvoError
from flowvo.geometry import skew, so3_exp, so3_log
from flowvo.kitti.poses import read_kitti_poses
from flowvo.kitti.sequence import KittiSequence
from flowvo.metrics.error_split import kitti_errors, on_true_path
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M
from flowvo.metrics.rotation_bias import step_rotation_errors

CORNERS, CORNER_QUALITY, CORNER_SPACING_PX = 1500, 0.005, 8
WINDOW_PX, LEVELS, RETURN_PX = 21, 4, 0.1
ESSENTIAL_THRESHOLD_PX, CAUCHY_PX = 0.5, 0.1
STILL_PX, MIN_TRACKS = 0.3, 30
LUCAS_KANADE_CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01)


def _tracks(previous: np.ndarray, current: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corners of ``previous`` and where they moved in ``current`` (each (M, 2) float64 pixels), checked both ways."""
    corners = cv2.goodFeaturesToTrack(previous, CORNERS, CORNER_QUALITY, CORNER_SPACING_PX)
    if corners is None:
        return np.zeros((0, 2)), np.zeros((0, 2))
    options = {"winSize": (WINDOW_PX, WINDOW_PX), "maxLevel": LEVELS, "criteria": LUCAS_KANADE_CRITERIA}
    moved, found, _ = cv2.calcOpticalFlowPyrLK(previous, current, corners, None, **options)
    back, found_back, _ = cv2.calcOpticalFlowPyrLK(current, previous, moved, None, **options)
    kept = (found[:, 0] == 1) & (found_back[:, 0] == 1) & (np.linalg.norm((back - corners)[:, 0], axis=1) < RETURN_PX)
    return corners[kept, 0].astype(np.float64), moved[kept, 0].astype(np.float64)


def _sampson_px(R: np.ndarray, t: np.ndarray, rays_prev: np.ndarray, rays_next: np.ndarray, focal_px: float
                ) -> np.ndarray:
    """The Sampson distances (pixels) of ray pairs (N, 3) under ``E = [t]x R``."""
    E = skew(t) @ R
    lines_next, lines_prev = rays_prev @ E.T, rays_next @ E
    residual = (rays_next * lines_next).sum(axis=1)
    return residual / np.sqrt(lines_next[:, 0] ** 2 + lines_next[:, 1] ** 2 + lines_prev[:, 0] ** 2
                              + lines_prev[:, 1] ** 2) * focal_px


def step_rotation(previous: np.ndarray, current: np.ndarray, K: np.ndarray) -> np.ndarray:
    """The camera's rotation from ``previous`` to ``current`` (axis-angle, radians, in the previous camera's frame);
    zero for a standstill or too few tracks."""
    points_prev, points_next = _tracks(previous, current)
    if len(points_prev) < MIN_TRACKS or np.median(np.linalg.norm(points_next - points_prev, axis=1)) < STILL_PX:
        return np.zeros(3)
    E, mask = cv2.findEssentialMat(points_prev, points_next, K, cv2.USAC_MAGSAC, 0.999, ESSENTIAL_THRESHOLD_PX)
    if E is None or E.shape != (3, 3):
        return np.zeros(3)
    R_a, R_b, t = cv2.decomposeEssentialMat(E[:3])
    R = min((R_a, R_b), key=lambda R: np.linalg.norm(so3_log(R)))  # a car turns by degrees a step, never by
    # the twisted pair's 180; the Sampson error does not see the sign of t
    inliers = mask[:, 0] > 0
    K_inverse = np.linalg.inv(K)
    rays_prev = np.c_[points_prev[inliers], np.ones(inliers.sum())] @ K_inverse.T
    rays_next = np.c_[points_next[inliers], np.ones(inliers.sum())] @ K_inverse.T
    t = t[:, 0] / np.linalg.norm(t)
    across, up = np.cross(t, [0.0, 1.0, 0.0]), np.cross(t, [1.0, 0.0, 0.0])  # two directions off t

    def refitted(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        direction = t + x[3] * across + x[4] * up
        return so3_exp(x[:3]) @ R, direction / np.linalg.norm(direction)

    x = least_squares(lambda x: _sampson_px(*refitted(x), rays_prev, rays_next, K[0, 0]), np.zeros(5),
                      loss="cauchy", f_scale=CAUCHY_PX).x
    R_next_prev, _ = refitted(x)
    return so3_log(R_next_prev.T)


def second_opinion(sequence: KittiSequence, width_px: int) -> np.ndarray:
    """The second opinion's poses (N, 4, 4) of the sequence's frames: its step rotations chained, no translation."""
    height, width = sequence.image_size_hw
    size = (width_px, int(round(height * width_px / width)))
    K = CameraIntrinsics.from_matrix(sequence.calibration.K0).scaled(size[0] / width, size[1] / height).K
    poses = [np.eye(4)]
    previous = None
    for image in sequence.images():
        image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
        if previous is not None:
            pose = poses[-1].copy()
            pose[:3, :3] = pose[:3, :3] @ so3_exp(step_rotation(previous, image, K))
            poses.append(pose)
        previous = image
    return np.stack(poses)


def report(T_gt: np.ndarray, T_run: np.ndarray, T_second: np.ndarray, lengths_m: tuple[float, ...]) -> list[str]:
    """The markdown lines: the three scores on the truth's path and the step errors' correlation per axis."""
    run, second = on_true_path(T_gt, T_run), on_true_path(T_gt, T_second)
    rows = (("the run against the truth", T_gt, run), ("the second opinion against the truth", T_gt, second),
            ("the run against the second opinion", second, run))
    lines = ["| rotations on the truth's path | r_err deg/m | t_err % |", "| --- | --- | --- |"]
    for label, reference, poses in rows:
        metric = kitti_errors(reference, poses, lengths_m)
        lines.append(f"| {label} | {metric['r_err_deg_per_m']:.4f} | {metric['t_err_percent']:.2f} |")
    errors = [step_rotation_errors(T_gt, T) for T in (T_run, T_second)]
    correlation = [np.corrcoef(errors[0][:, axis], errors[1][:, axis])[0, 1] for axis in range(3)]
    rms = [np.degrees(np.sqrt((e ** 2).mean(axis=0))) for e in errors]
    lines += ["", "Step rotation errors against the truth (pitch / yaw / roll): rms the run "
              + " / ".join(f"{v:.4f}" for v in rms[0]) + " deg, the second opinion "
              + " / ".join(f"{v:.4f}" for v in rms[1]) + " deg; their correlation "
              + " / ".join(f"{v:+.2f}" for v in correlation) + "."]
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path, help="KITTI-layout root with poses/SEQUENCE.txt")
    parser.add_argument("sequence", help="the sequence, e.g. 07")
    parser.add_argument("run", type=Path, help="the run's KITTI pose file (the same frames)")
    parser.add_argument("--lengths", type=float, nargs="+", default=list(SEGMENT_LENGTHS_M),
                        help="sub-path lengths of the KITTI metric, m (default the devkit's 100..800)")
    parser.add_argument("--width", type=int, default=620, help="frames area-resized to this width, px (default 620)")
    args = parser.parse_args(argv)
    if args.width < 16 or not all(length > 0 for length in args.lengths):
        parser.error("--width must be at least 16 px and --lengths positive")
    try:
        sequence = KittiSequence(args.root, args.sequence)
        T_gt = sequence.poses.T_world_cam
        prediction = read_kitti_poses(args.run)
        if len(prediction) != len(T_gt) or not prediction.is_complete:
            raise FlowvoError(f"holds {len(prediction)} poses; the truth has every one of {len(T_gt)} frames", args.run)
        try:
            kitti_errors(T_gt, T_gt, tuple(args.lengths))  # before the second opinion's minute of work
        except ValueError as error:  # the drive is shorter than every sub-path
            raise FlowvoError(f"{error}; give shorter --lengths", sequence.pose_path) from None
        lines = report(T_gt, prediction.T_world_cam, second_opinion(sequence, args.width), tuple(args.lengths))
    except FlowvoError as error:
        print(f"second_opinion_rotations: {error}", file=sys.stderr)
        return 2
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
