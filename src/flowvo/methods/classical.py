"""``classical``: the sparse baseline. KLT-tracked corners at full resolution, essential matrix with
RANSAC, recoverPose.

Monocular VO has no metric scale. Two protocols: ``gt`` takes each step's length from the ground truth
(the usual protocol for evaluating monocular methods on KITTI, labelled so), ``height`` recovers it from
the camera height above the road by the median height of triangulated points below the horizon, as
VISO2-M does. Lens distortion is removed from the tracked points.
"""

from __future__ import annotations

import logging

import cv2
import numpy as np

from flowvo.camera import Camera, undistort_points
from flowvo.geometry import invert_se3
from flowvo.methods.base import NoWindow

_log = logging.getLogger(__name__)
MIN_TRACKS = 30
STILL_FLOW_PX = 0.3


def track_corners(prev: np.ndarray, following: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corners of ``prev`` tracked into ``following`` by pyramidal KLT with a forward-backward check."""
    corners = cv2.goodFeaturesToTrack(prev, maxCorners=1500, qualityLevel=0.01, minDistance=7, blockSize=7)
    if corners is None:
        return np.zeros((0, 2)), np.zeros((0, 2))
    params = {"winSize": (21, 21), "maxLevel": 3,
              "criteria": (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01)}
    forward, status, _ = cv2.calcOpticalFlowPyrLK(prev, following, corners, None, **params)
    backward, status_back, _ = cv2.calcOpticalFlowPyrLK(following, prev, forward, None, **params)
    good = (status[:, 0] == 1) & (status_back[:, 0] == 1) & (np.linalg.norm(backward - corners, axis=2)[:, 0] < 1.0)
    return corners[good, 0].astype(np.float64), forward[good, 0].astype(np.float64)


def relative_motion(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray] | None:
    """Unit-translation motion ``T_prev_next`` (4, 4) and the inlier mask, or None when degenerate."""
    if len(points_prev) < MIN_TRACKS:
        return None
    K = np.ascontiguousarray(K, dtype=np.float64)  # OpenCV reads a strided view as its buffer
    E, mask = cv2.findEssentialMat(points_prev, points_next, K, cv2.RANSAC, 0.999, 1.0)
    if E is None or E.shape != (3, 3):
        return None
    inliers, R, t, mask = cv2.recoverPose(E, points_prev, points_next, K, mask=mask)
    if inliers < MIN_TRACKS // 2:
        return None
    T_next_prev = np.eye(4)
    T_next_prev[:3, :3], T_next_prev[:3, 3] = R, t[:, 0]
    return invert_se3(T_next_prev), mask[:, 0] > 0


def ground_height_unit(points_prev, points_next, T_prev_next, K, image_hw) -> float | None:
    """Camera height above the road in units of the (unit) step, from points below the horizon."""
    h, w = image_hw
    road = (points_prev[:, 1] > K[1, 2] + 0.1 * h) & (np.abs(points_prev[:, 0] - K[0, 2]) < 0.3 * w)
    if road.sum() < 12:
        return None
    P0 = K @ np.eye(3, 4)
    P1 = K @ invert_se3(T_prev_next)[:3]
    X = cv2.triangulatePoints(P0, P1, points_prev[road].T, points_next[road].T)
    X = (X[:3] / X[3]).T
    X = X[(X[:, 2] > 0) & (X[:, 2] < 60) & (X[:, 1] > 0)]
    if len(X) < 8:
        return None
    return float(np.median(X[:, 1]))  # road points: y (down) is the height below the camera


class ClassicalTracker:
    """Streaming form of the baseline, in the two stages of a per-frame step: ``tracks(prev, cur)``
    (KLT, thread-safe) and ``motion(tracks, image_hw)`` (in frame order) returning ``T_prev_cur`` (4, 4);
    metric scale from ``step_lengths_m`` (GT protocol, step i = frame i -> i+1) or, when None, from the
    camera height."""

    def __init__(self, K: np.ndarray, step_lengths_m: np.ndarray | None, camera_height_m: float) -> None:
        self.K = K
        self.camera_height_m = camera_height_m
        self.step_lengths_m = step_lengths_m
        self.index = 0
        self.last_scale = 1.0
        self.last_motion = np.eye(4)
        self.fitted_steps = 0  # steps whose motion was fitted to their tracks
        self.still_steps = 0  # steps taken as a standstill
        self.scaled_steps = 0  # fitted steps whose length was measured (the camera height or the ground truth)

    @staticmethod
    def tracks(previous: np.ndarray, current: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Corner tracks between two frames (see :func:`track_corners`)."""
        return track_corners(previous, current)

    def motion(self, tracks: tuple[np.ndarray, np.ndarray], image_hw: tuple[int, int]) -> np.ndarray:
        """Motion of the next step from its tracks."""
        p0, p1 = tracks
        still = len(p0) >= MIN_TRACKS and np.median(np.linalg.norm(p1 - p0, axis=1)) < STILL_FLOW_PX
        result = None if still else relative_motion(p0, p1, self.K)
        self.still_steps += int(still)
        if result is None:
            motion = np.eye(4) if still else self.last_motion
        else:
            motion, inliers = result
            self.fitted_steps += 1
            if self.step_lengths_m is not None:
                scale = self.step_lengths_m[self.index]
                self.scaled_steps += 1
            else:
                height = ground_height_unit(p0[inliers], p1[inliers], motion, self.K, image_hw)
                measured = bool(height and height > 1e-3)
                self.scaled_steps += int(measured)
                scale = self.camera_height_m / height if measured else self.last_scale
                scale = float(np.clip(scale, 0.0, 4.0))
                self.last_scale = scale
            motion = motion.copy()
            motion[:3, 3] *= scale
        self.last_motion = motion
        self.index += 1
        return motion


class ClassicalStep(NoWindow):
    """The baseline as a per-frame step: full-resolution frames, KLT tracks (undistorted), the tracker's
    motion; camera-height scale, or the ground-truth step lengths (labelled so) when ``gt_step_lengths_m``
    is given."""

    motion_stage = "geometry"
    opencv_threads: int | None = None

    def __init__(self, camera: Camera, gt_step_lengths_m: np.ndarray | None = None,
                 image_size_hw: tuple[int, int] | None = None) -> None:
        self.camera = camera
        self.image_size_hw = image_size_hw
        self.warnings: list[str] = []
        self.tracker = ClassicalTracker(camera.K, gt_step_lengths_m, camera.camera_height_m)
        self.scale_source = "gt" if gt_step_lengths_m is not None else "height"
        self.label = "classical (KLT + essential matrix, " + (
            "GT scale)" if gt_step_lengths_m is not None else "camera-height scale)")

    def prepare(self, image: np.ndarray) -> np.ndarray:
        """Full-resolution frames."""
        return image

    def complete(self, prepared: np.ndarray) -> np.ndarray:
        """The prepared frame: nothing is left to do."""
        return prepared

    def flow(self, previous: np.ndarray, current: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """KLT corner tracks, in undistorted pixels."""
        tracks = self.tracker.tracks(previous, current)
        if self.camera.distortion.is_none:
            return tracks
        return tuple(undistort_points(points, self.camera.K, self.camera.distortion).astype(np.float64)
                     for points in tracks)

    def motion(self, times_s: tuple[float, float], previous: np.ndarray, flow: tuple[np.ndarray, np.ndarray]
               ) -> np.ndarray:
        """``T_prev_cur`` from the tracks."""
        return self.tracker.motion(flow, previous.shape)

    def flush(self) -> list[tuple[float, np.ndarray]]:
        """Nothing is held back. A drive on which the method measured nothing gets a warning (logged, and in
        :meth:`summary` for run.json): no step's motion fitted (too few corners tracked: tiny or blank frames,
        the path is standing still), or, moving, no step's length measured from the camera height (no road
        texture below the horizon: every length is the first step's 1 m, made up)."""
        tracker, size = self.tracker, self.image_size_hw
        frames = f" (frames of {size[1]}x{size[0]} px)" if size is not None else ""
        if tracker.index and not tracker.fitted_steps and tracker.still_steps < tracker.index:
            self.warnings.append(f"the classical method fitted the motion of none of the {tracker.index} steps: fewer "
                                 f"than {MIN_TRACKS} corners tracked in each{frames}; the path is not measured")
        elif tracker.fitted_steps and not tracker.scaled_steps:
            self.warnings.append(f"the classical method measured the camera height in none of the "
                                 f"{tracker.fitted_steps} steps it fitted: too few tracked corners on the road"
                                 f"{frames}, so every length is made up (1 m a step); use --method flowvo, or "
                                 "--scale-from gt where ground truth exists")
        for warning in self.warnings:
            _log.warning("warning: %s", warning)
        return []

    def summary(self) -> dict:
        """Where the metric scale came from, and how many steps had their motion fitted and their length
        measured."""
        tracker = self.tracker
        return {"scale_source": self.scale_source, "warnings": list(self.warnings), "classical_steps": {
            "fitted": tracker.fitted_steps, "length_measured": tracker.scaled_steps, "standstill": tracker.still_steps,
            "repeated_last_motion": tracker.index - tracker.fitted_steps - tracker.still_steps}}
