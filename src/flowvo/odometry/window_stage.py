"""The default method's stage behind its per-frame steps: the scale window (:mod:`flowvo.odometry.scale_window`),
then for ``flowvo-ba`` the bundle stage (:mod:`flowvo.odometry.bundle_window`), and the motions given out in
metres.

The steps arrive in the method's units (KITTI camera heights: metres for a camera 1.65 m high); every motion and
step record leaves in metres, ``metres_per_unit`` times as long. Motions are ``T_prev_cur`` (4x4); times in seconds;
landmarks in undistorted working pixels.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from flowvo.odometry.bundle_window import BundleWindow
from flowvo.odometry.landmark_tracks import Landmarks
from flowvo.odometry.scale_window import ScaleWindow, StepRecord, StepScale


def motion_in_metres(motion: np.ndarray, metres_per_unit: float) -> np.ndarray:
    """A motion (4x4) in the method's units with its translation in metres (the same array where the unit is a
    metre)."""
    if metres_per_unit == 1.0:
        return motion
    scaled = motion.copy()
    scaled[:3, 3] *= metres_per_unit
    return scaled


class WindowStage:
    """The scale ``window`` and, for ``flowvo-ba``, the ``bundle`` stage behind it (None: none), giving motions out
    in metres (``metres_per_unit``: the camera's height over KITTI's)."""

    def __init__(self, window: ScaleWindow, bundle: BundleWindow | None, metres_per_unit: float) -> None:
        self.window, self.bundle, self.metres_per_unit = window, bundle, metres_per_unit
        self.latency_frames = window.latency_frames + (bundle.latency_frames if bundle else 0)
        self._landmark_views: dict[float, Landmarks] = {}  # by frame time, until the bundle takes them
        self._records_m: list[StepRecord] = []  # the window's records in metres, as far as converted

    def keep_landmarks(self, previous: tuple[float, Landmarks] | None, current: tuple[float, Landmarks]) -> None:
        """A step's frames' landmark tracks (time, landmarks), for the bundle stage; ``previous`` only for the
        drive's first step (None after)."""
        if previous is not None and not self._landmark_views:  # the drive's first frame
            self._landmark_views[previous[0]] = previous[1]
        self._landmark_views[current[0]] = current[1]

    def push(self, time_s: float, measured: StepScale | None) -> list[tuple[float, np.ndarray]]:
        """The step ending at ``time_s`` (None: a standstill) into the window; the motions now final, in metres."""
        return self._in_metres(self._bundled(self.window.push(time_s, measured)))

    def flush(self) -> list[tuple[float, np.ndarray]]:
        """The motions still in the window (and the bundle stage) at the end of the drive, in metres."""
        final = self._bundled(self.window.flush())
        return self._in_metres(final if self.bundle is None else final + self.bundle.flush())

    def records(self) -> list[StepRecord]:
        """What became of each final step so far, lengths in metres."""
        if self.metres_per_unit == 1.0:
            return self.window.records
        self._records_m += [record._replace(length_m=record.length_m * self.metres_per_unit)
                            for record in self.window.records[len(self._records_m):]]
        return self._records_m

    def _in_metres(self, motions: list[tuple[float, np.ndarray]]) -> list[tuple[float, np.ndarray]]:
        return [(time_s, motion_in_metres(motion, self.metres_per_unit)) for time_s, motion in motions]

    def _bundled(self, final: list[tuple[float, np.ndarray]]) -> list[tuple[float, np.ndarray]]:
        """The scale window's ``final`` motions through the bundle stage, each step's length sigma from the
        window's records."""
        if self.bundle is None or not final:
            return final
        records = self.window.records[len(self.window.records) - len(final):]
        bundled = []
        for (time_s, motion), record in zip(final, records, strict=True):
            if not self.bundle.started:
                first_time_s = min(self._landmark_views)
                bundled += self.bundle.push(first_time_s, None, *self._landmark_views.pop(first_time_s))
            bundled += self.bundle.push(time_s, motion, *self._landmark_views.pop(time_s), record.log_sigma)
        return bundled

    def summary(self) -> dict:
        """The window's latency (frames: how late each motion is final), how many steps each kind of measurement
        reached, the median standard deviation of a step's log length and how many moving steps no measurement of
        the scale reached (:class:`StepRecord`); the bundle stage's counts."""
        records = self.window.records
        sigmas = [record.log_sigma for record in records if record.log_sigma is not None]
        kept = {"scale_window": {"latency_frames": self.window.latency_frames, "window_s": self.window.window_s,
                                 "steps_measured_by": dict(Counter(record.measured_by for record in records)),
                                 "median_length_log_sigma": float(np.median(sigmas)) if sigmas else None,
                                 "unscaled_steps": sum(record.unscaled for record in records)}}
        if self.bundle is not None:
            kept["bundle"] = {"latency_frames": self.bundle.latency_frames, "frames": self.bundle.frames,
                              "every": self.bundle.every, "solves": self.bundle.solves,
                              "dropped_observations": self.bundle.dropped_observations}
        return kept
