"""Local bundle adjustment: the poses of a window of frames and the points they see, refined jointly.

Every observation of a point in a frame is a reprojection residual, in pixels, under a robust loss (Cauchy by
default: a wrong track counts little once its residual is several sigmas); every step between consecutive frames
keeps the front end's motion as a prior with its own standard deviations (rotation and translation), which
is what holds the metric scale: reprojections alone fix the poses only up to scale. The first ``fixed_frames``
poses are held where they are (the gauge: what lies before them is final). Solved by GTSAM's
Levenberg-Marquardt (sparse Cholesky that eliminates the points first, as every bundle adjuster does).

Pure computation over NumPy arrays. Poses are camera-to-world ``T_world_cam`` (4x4, metres), camera frame x right,
y down, z forward; points in the world frame (metres); pixels are undistorted pixels of the camera ``K``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from flowvo.geometry import invert_se3
from flowvo.optional import import_optional

PIXEL_SIGMA_PX = 0.7  # a Lucas-Kanade track's error, pixels (real clips: forward-backward checked tracks)
LOSS_SCALE_SIGMAS = 2.0  # the robust loss's scale, in pixel sigmas
INLIER_SIGMAS = 3.0  # after the solve, an observation whose residual is within this many sigmas is an inlier
MAX_ITERATIONS = 3  # per solve: a window solved every frame starts where the last solve ended (real clips: 2, 3
# or 10 iterations alike to 0.01 points of t_err, 26 / 40 / 59 ms a frame on clip 07)


class BundleResult(NamedTuple):
    """The refined poses ``T_world_cam`` (N, 4, 4) and points (P, 3, world, metres), which observations are
    inliers after the solve (O,) and their reprojection error after it (px, rms)."""

    T_world_cam: np.ndarray
    points_world: np.ndarray
    inlier: np.ndarray
    rms_after_px: float


def reprojection_errors_px(T_world_cam: np.ndarray, points_world: np.ndarray, frame: np.ndarray,
                           point: np.ndarray, observed_px: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Distance (O,) between each observed pixel (O, 2) and where point ``point[o]`` projects in frame
    ``frame[o]``; infinite for a point behind that camera."""
    T_cam_world = invert_se3(T_world_cam)[frame]
    in_camera = np.einsum("oij,oj->oi", T_cam_world[:, :3, :3], points_world[point]) + T_cam_world[:, :3, 3]
    projected = in_camera @ K.T
    with np.errstate(divide="ignore", invalid="ignore"):
        distance = np.linalg.norm(projected[:, :2] / projected[:, 2:3] - observed_px, axis=1)
    return np.where(in_camera[:, 2] > 0, distance, np.inf)


def adjust_bundle(T_world_cam: np.ndarray, points_world: np.ndarray, frame: np.ndarray, point: np.ndarray,
                  observed_px: np.ndarray, K: np.ndarray, step_motions: np.ndarray, step_sigmas: np.ndarray,
                  fixed_frames: int = 1,
                  pixel_sigma_px: float = PIXEL_SIGMA_PX, loss: str = "cauchy", max_iterations: int = MAX_ITERATIONS
                  ) -> BundleResult:
    """Refine poses and points (see the module docstring).

    ``T_world_cam`` (N, 4, 4) and ``points_world`` (P, 3): where the solve starts; observation o: point
    ``point[o]`` seen at ``observed_px[o]`` in frame ``frame[o]``; ``step_motions`` (N - 1, 4, 4): each step's
    prior ``T_prev_cur``, with ``step_sigmas`` (N - 1, 6) its standard deviations, rotation (rad) then
    translation (m), about and along the axes of the step's first camera; ``loss``: "cauchy", "huber" or
    "none" (plain least squares); at most ``max_iterations`` of Levenberg-Marquardt.
    """
    gtsam = import_optional("gtsam", "bundle adjustment", "ba")
    count = len(T_world_cam)
    if step_sigmas.shape != (count - 1, 6) or step_motions.shape != (count - 1, 4, 4):
        raise ValueError(f"{count} poses need ({count - 1}, 4, 4) step motions and ({count - 1}, 6) sigmas, got "
                         f"{step_motions.shape} and {step_sigmas.shape}")
    pose_key, point_key = (lambda i: gtsam.symbol("x", i)), (lambda j: gtsam.symbol("l", j))
    graph, start = gtsam.NonlinearFactorGraph(), gtsam.Values()
    poses = [gtsam.Pose3(T) for T in np.asarray(T_world_cam, np.float64)]
    for i, pose in enumerate(poses):
        start.insert(pose_key(i), pose)
        if i < fixed_frames:
            graph.add(gtsam.NonlinearEqualityPose3(pose_key(i), pose))
        if i > 0:
            graph.add(gtsam.BetweenFactorPose3(pose_key(i - 1), pose_key(i), gtsam.Pose3(step_motions[i - 1]),
                                               gtsam.noiseModel.Diagonal.Sigmas(step_sigmas[i - 1])))
    for j, xyz in enumerate(np.asarray(points_world, np.float64)):
        start.insert(point_key(j), xyz)
    calibration = gtsam.Cal3_S2(K[0, 0], K[1, 1], K[0, 1], K[0, 2], K[1, 2])
    pixel_noise = _pixel_noise(gtsam, pixel_sigma_px, loss)
    for i, j, xy in zip(frame.tolist(), point.tolist(), np.asarray(observed_px, np.float64), strict=True):
        graph.add(gtsam.GenericProjectionFactorCal3_S2(xy, pixel_noise, pose_key(i), point_key(j), calibration))
    parameters = gtsam.LevenbergMarquardtParams()
    parameters.setMaxIterations(max_iterations)
    parameters.setLinearSolverType("SEQUENTIAL_CHOLESKY")  # 3x faster than the multifrontal default here: a
    # window's graph is small (6 poses, 200 points: 12 against 35 ms a solve, the same poses to 1e-15)
    solved = gtsam.LevenbergMarquardtOptimizer(graph, start, parameters).optimize()
    refined = np.stack([solved.atPose3(pose_key(i)).matrix() for i in range(count)])
    points = np.stack([solved.atPoint3(point_key(j)) for j in range(len(points_world))]) if len(points_world) \
        else np.zeros((0, 3))
    after = reprojection_errors_px(refined, points, frame, point, observed_px, K)
    inlier = after <= INLIER_SIGMAS * pixel_sigma_px
    return BundleResult(refined, points, inlier, _rms(after[inlier]))


def _pixel_noise(gtsam, pixel_sigma_px: float, loss: str):
    """The reprojection residual's noise model: isotropic ``pixel_sigma_px``, under the robust ``loss``."""
    isotropic = gtsam.noiseModel.Isotropic.Sigma(2, pixel_sigma_px)
    if loss == "none":
        return isotropic
    estimators = {"cauchy": gtsam.noiseModel.mEstimator.Cauchy, "huber": gtsam.noiseModel.mEstimator.Huber}
    if loss not in estimators:
        raise ValueError(f"loss must be cauchy, huber or none, got {loss!r}")
    return gtsam.noiseModel.Robust.Create(estimators[loss].Create(LOSS_SCALE_SIGMAS), isotropic)


def _rms(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(values)))) if len(values) else 0.0
