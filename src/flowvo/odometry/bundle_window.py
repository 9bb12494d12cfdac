"""The bundle stage of ``flowvo-ba``: the last frames' poses and the points they track, refined jointly.

Behind the scale window (:mod:`flowvo.odometry.scale_window`), whose motions arrive with their metric lengths,
this stage
keeps the last ``frames`` frames, the points tracked through them (:mod:`flowvo.odometry.landmark_tracks`) and a point
estimate for every track seen in ``MIN_VIEWS`` frames. Every ``every`` frames it runs a local bundle adjustment
(:func:`flowvo.odometry.bundle_adjustment.adjust_bundle`): the oldest frame held (its pose is final), each step's motion
from the scale window as a prior that keeps its length (the window's own standard deviation of it) and lets its
rotation and direction follow the points. When a frame leaves the window, the motion to the next one is final:
each motion comes out ``frames - 1`` frames after the scale window gave it, with the bundle's translation and,
by default, the scale window's rotation: the bundle's rotations drift with its tracks' bias (real clips 06 and 07,
synthetic replays; ``BundleSettings(own_rotations=True)`` gives them), its translations are better. Observations
that end a solve more than a few pixel sigmas off are dropped.

Pure computation over NumPy arrays (the solve is GTSAM's). Motions ``T_prev_cur`` (4x4, metres); poses
``T_world_cam`` in the window's own world (the first frame's camera); undistorted working pixels.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from flowvo.geometry import invert_se3
from flowvo.odometry.bundle_adjustment import adjust_bundle
from flowvo.odometry.two_view import EssentialMotion, translation_parallax_px, triangulate
from flowvo.optional import import_optional

FRAMES = 10  # frames in the window (the latency it adds is one less)
EVERY = 1  # frames between solves
MIN_VIEWS = 3  # a track counts once seen in this many frames of the window
ROTATION_SIGMA_RAD = math.radians(0.1)  # a step's rotation prior, each axis (the front end's are 0.02-0.05 deg off)
DIRECTION_SIGMA = 0.01  # a step's sideways and vertical translation prior, as a fraction of its length (0.6 deg)
LENGTH_LOG_SIGMA = 0.05  # a step's length prior where the scale window gave no standard deviation (log)
MIN_TRANSLATION_SIGMA_M = 0.002  # translation priors at least this (standstill steps)
MIN_PARALLAX_RAD = 0.001  # a track moves this much between its first and last view beyond the rotation, at least
# (over the focal length: 0.35 px at 620 px wide)


@dataclass(frozen=True)
class BundleSettings:
    """How the bundle stage runs: ``frames`` in the window, a solve every ``every`` frames, the reprojections'
    robust ``loss`` ("cauchy", "huber" or "none"), and whether the motions it gives keep the scale window's
    rotations (``own_rotations`` False) or take the bundle's own."""

    frames: int = FRAMES
    every: int = EVERY
    loss: str = "cauchy"
    own_rotations: bool = False


@dataclass
class _Frame:
    """One frame of the window: its time, pose, the prior of the step that reached it (None for the first
    frame) and its tracks' ids (M,) and undistorted pixels (M, 2)."""

    time_s: float
    T_world_cam: np.ndarray
    motion: np.ndarray | None
    step_sigmas: np.ndarray | None
    ids: np.ndarray
    px: np.ndarray


class BundleWindow:
    """The bundle stage (see the module docstring) for the camera ``K`` (3x3, undistorted working pixels)."""

    def __init__(self, K: np.ndarray, settings: BundleSettings = BundleSettings()) -> None:
        if settings.frames < 2 or settings.every < 1:
            raise ValueError(f"the bundle window needs 2 frames or more and a solve every frame or less often, got "
                             f"{settings.frames} frames, every {settings.every}")
        import_optional("gtsam", "flowvo-ba's bundle adjustment", "ba")  # before the drive, not at its first solve
        self.K = np.asarray(K, np.float64)
        self.frames, self.every, self.loss = settings.frames, settings.every, settings.loss
        self.own_rotations = settings.own_rotations
        self._window: deque[_Frame] = deque()
        self._points: dict[int, np.ndarray] = {}  # track id -> world point (metres)
        self._pushed = 0
        self.solves = 0
        self.dropped_observations = 0

    @property
    def started(self) -> bool:
        """True once the first frame is in."""
        return bool(self._window)

    @property
    def latency_frames(self) -> int:
        """How many frames after it arrives a motion leaves the window."""
        return self.frames - 1

    def push(self, time_s: float, motion: np.ndarray | None, ids: np.ndarray, px: np.ndarray,
             length_log_sigma: float | None = None) -> list[tuple[float, np.ndarray]]:
        """Add the frame at ``time_s`` with its tracks, reached by ``motion`` (``T_prev_cur``; None for the first
        frame) whose length's log has the standard deviation ``length_log_sigma``; the motions now final."""
        if motion is None:
            if self._window:
                raise ValueError("only the first frame comes without a motion")
            self._window.append(_Frame(time_s, np.eye(4), None, None, ids, px))
            return []
        if not self._window:
            raise ValueError("the first frame must come first, without a motion")
        length_m = float(np.linalg.norm(motion[:3, 3]))
        log_sigma = LENGTH_LOG_SIGMA if length_log_sigma is None else min(length_log_sigma, 1.0)
        sideways, along = (max(length_m * sigma, MIN_TRANSLATION_SIGMA_M) for sigma in (DIRECTION_SIGMA, log_sigma))
        sigmas = np.array([ROTATION_SIGMA_RAD] * 3 + [sideways, sideways, along])
        self._window.append(_Frame(time_s, self._window[-1].T_world_cam @ motion, motion, sigmas, ids, px))
        self._pushed += 1
        if self._pushed % self.every == 0:
            self._solve()
        return self._leaving(self.frames)

    def flush(self) -> list[tuple[float, np.ndarray]]:
        """Solve once more and give every motion still in the window."""
        if len(self._window) > 1:
            self._solve()
        return self._leaving(1)

    def _leaving(self, keep: int) -> list[tuple[float, np.ndarray]]:
        """Let frames go from the front until ``keep`` remain: the motions from each to the next."""
        final = []
        while len(self._window) > keep:
            leaving = self._window.popleft()
            following = self._window[0]
            motion = invert_se3(leaving.T_world_cam) @ following.T_world_cam
            if not self.own_rotations:
                motion[:3, :3] = following.motion[:3, :3]
            final.append((following.time_s, motion))
        return final

    def _solve(self) -> None:
        """One bundle adjustment of the window; poses, points and observations updated in place."""
        window = list(self._window)
        frame = np.concatenate([np.full(len(f.ids), i) for i, f in enumerate(window)])
        ids = np.concatenate([f.ids for f in window])
        px = np.concatenate([f.px for f in window]).astype(np.float64)
        unique_ids, point, views = np.unique(ids, return_inverse=True, return_counts=True)
        poses = np.stack([f.T_world_cam for f in window])
        points = np.full((len(unique_ids), 3), np.nan)
        known = np.array([track in self._points for track in unique_ids.tolist()], bool)
        for j in np.flatnonzero(known):
            points[j] = self._points[int(unique_ids[j])]
        new = ~known & (views >= MIN_VIEWS)
        points[new] = self._triangulated(poses, frame, px, point, np.flatnonzero(new))
        used = ~np.isnan(points[:, 0])
        self._points = {int(track): points[j] for j, track in enumerate(unique_ids) if used[j]}
        if not used.any():
            return
        kept = used[point]
        renumbered = np.cumsum(used) - 1
        result = adjust_bundle(poses, points[used], frame[kept], renumbered[point[kept]], px[kept], self.K,
                               np.stack([f.motion for f in window[1:]]), np.stack([f.step_sigmas for f in window[1:]]),
                               loss=self.loss)
        self.solves += 1
        for f, pose in zip(window, result.T_world_cam, strict=True):
            f.T_world_cam = pose
        for track, xyz in zip(unique_ids[used].tolist(), result.points_world, strict=True):
            self._points[track] = xyz
        outliers = np.zeros(len(ids), bool)
        outliers[np.flatnonzero(kept)[~result.inlier]] = True
        self.dropped_observations += int(outliers.sum())
        start = 0
        for f in window:
            own = ~outliers[start:start + len(f.ids)]
            start += len(f.ids)
            f.ids, f.px = f.ids[own], f.px[own]

    def _triangulated(self, poses: np.ndarray, frame: np.ndarray, px: np.ndarray, point: np.ndarray,
                      tracks: np.ndarray) -> np.ndarray:
        """World points (len(tracks), 3) of the ``tracks`` (indices into ``point``'s numbering), each from its first
        and last view in the window (:func:`flowvo.odometry.two_view.triangulate`, the midpoint method, with the metric
        motion between the two frames); NaNs where the view moved less than ``MIN_PARALLAX_RAD`` beyond the rotation
        or the point lies behind a camera. Observations are in frame order: a track's earliest row is its first view."""
        points = np.full((len(tracks), 3), np.nan)
        if not len(tracks):
            return points
        rows = np.arange(len(point))
        first, last = np.full(point.max() + 1, len(point)), np.full(point.max() + 1, -1)
        np.minimum.at(first, point, rows)
        np.maximum.at(last, point, rows)
        first, last = first[tracks], last[tracks]
        pairs = np.stack([frame[first], frame[last]], axis=1)
        for a, b in np.unique(pairs, axis=0).tolist():
            group = np.flatnonzero((pairs[:, 0] == a) & (pairs[:, 1] == b))
            T_b_a = invert_se3(poses[b]) @ poses[a]
            motion = EssentialMotion(T_b_a[:3, :3], T_b_a[:3, 3], np.ones(len(group), bool))
            seen_a, seen_b = px[first[group]], px[last[group]]
            in_a = triangulate(seen_a, seen_b, self.K, motion)  # metres: the motion's translation is metric
            in_b_z = in_a @ motion.R[2] + motion.t_dir[2]
            parallax_rad = translation_parallax_px(seen_a, seen_b, self.K, motion.R) / self.K[0, 0]
            usable = (parallax_rad >= MIN_PARALLAX_RAD) & (in_a[:, 2] > 0) & (in_b_z > 0)
            points[group[usable]] = in_a[usable] @ poses[a][:3, :3].T + poses[a][:3, 3]
        return points
