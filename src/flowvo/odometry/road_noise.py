"""How noisy a drive's road flow is, read from its trusted road planes, and the baseline its road flow then needs.

A road point triangulated from a step has a relative depth error of its flow's error over its parallax (the motion
beyond the rotation), and on a plane its height errs alike: so a point's residual from the plane (a share of the
plane's distance) times its parallax is its flow's error in pixels. Real KITTI's road flow errs 0.16-0.26 px (the
robust spread over a plane's points, median over a clip), the real dash-cam's 0.8 px: its smooth, dark motorway seen
through a compressed 25 frames/s video. At one step's baseline there, the far road's parallax is a few times its flow's
error; its depths come out long (the mean of an inverse is larger than the inverse of a mean), so the road bends down
away from the camera, its planes tilt (their pitches scattered over 7.7 degrees) and most are refused. A road flow
that spans ``BASELINE_SNR`` times the flow's error (the near road's parallax over it) measures that camera's road as
flat as KITTI's; KITTI's road needs no more than its fixed baseline
(:data:`flowvo.odometry.road_key.BASELINE_PX`).

Pixels of the working frame; residuals as shares of the plane's distance.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from flowvo.odometry.numeric import median

BASELINE_SNR = 30.0  # the near road's parallax a road flow should span, in units of the flow's error (real dash-cam
# at 1.3 m, speed (1-s means) / planes trusted / candidates' pitch spread / far road off the plane: 32.0-33.1 m/s /
# 187 of 199 / 0.26 deg / 0.026; over one step 27.7-33.8 m/s / 82 / 7.7 deg / 0.21; 25 and 35 alike, 182 and 187
# planes); real KITTI 01, 03, 06 and 03 at 5 Hz need 9.9 px at most at 30, within the fixed 12
NOISE_PLANES = 20  # the trusted planes whose flow errors the drive's is the median of
MAX_RESIDUAL_SHARE = 0.5  # points further off the plane (share of its distance) are not the road's surface
MIN_NOISE_POINTS = 20  # a plane with fewer road points near it says nothing of the flow's error
MAD_TO_SIGMA = 1.4826  # the median absolute deviation of a normal distribution, in its standard deviations


def flow_error_px(residuals: np.ndarray, parallax_px: np.ndarray) -> float | None:
    """The road flow's error (pixels, a robust standard deviation) from road points' ``residuals`` (N,; shares of
    their plane's distance, :func:`flowvo.odometry.road_profile.road_residuals`) and their parallax (N,; pixels beyond
    the rotation): the points within ``MAX_RESIDUAL_SHARE`` of the plane; None with fewer than ``MIN_NOISE_POINTS``."""
    near = np.abs(residuals) < MAX_RESIDUAL_SHARE  # False for NaN
    if np.count_nonzero(near) < MIN_NOISE_POINTS:
        return None
    return MAD_TO_SIGMA * median(np.abs(residuals[near] * parallax_px[near]))


class RoadFlowNoise:
    """The road flow's error over the drive's last ``NOISE_PLANES`` trusted planes (module docstring), and the
    near road's parallax a road flow should span for it."""

    def __init__(self) -> None:
        self._errors_px: deque[float] = deque(maxlen=NOISE_PLANES)
        self.error_px: float | None = None  # their median (pixels; None before the first trusted plane)
        self.largest_error_px: float | None = None  # the largest that median has been since the drive's mounting

    def observe(self, residuals: np.ndarray, parallax_px: np.ndarray) -> None:
        """Learn from a trusted plane's road points: their residuals and parallax (see :func:`flow_error_px`)."""
        error_px = flow_error_px(residuals, parallax_px)
        if error_px is not None:
            self._errors_px.append(error_px)
            self.error_px = median(np.array(self._errors_px))
            self.largest_error_px = max(self.error_px, self.largest_error_px or 0.0)

    def forget(self) -> None:
        """Start afresh (the planes so far were fitted through a camera mounting the drive has just replaced)."""
        self._errors_px.clear()
        self.error_px = self.largest_error_px = None

    def baseline_px(self, fixed_px: float) -> float:
        """The near road's parallax a road flow should span (pixels): ``fixed_px``, or ``BASELINE_SNR`` times the
        flow's error where that is more."""
        return _spanned_px(fixed_px, self.error_px)

    def record(self, fixed_px: float, frame_px_per_px: float) -> dict:
        """For run.json, in the frames' own pixels (``frame_px_per_px`` of them to a working pixel; ``fixed_px``: the
        fixed baseline, working pixels): the road flow's error at the end and at its largest (None: no trusted plane
        since the drive's mounting), and the near road's parallax a road flow should span at the largest."""
        def frame_px(value_px: float | None) -> float | None:
            return None if value_px is None else round(value_px * frame_px_per_px, 3)
        return {"road_flow_error_px": frame_px(self.error_px),
                "road_flow_error_px_largest": frame_px(self.largest_error_px),
                "road_baseline_px_largest": frame_px(_spanned_px(fixed_px, self.largest_error_px))}


def _spanned_px(fixed_px: float, error_px: float | None) -> float:
    """The near road's parallax a road flow should span (pixels) where it errs ``error_px`` (None: not known yet)."""
    return fixed_px if error_px is None else max(fixed_px, BASELINE_SNR * error_px)
