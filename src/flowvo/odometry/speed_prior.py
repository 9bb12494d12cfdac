"""A smooth-speed prior for noisy per-frame step lengths: a causal robust line through recent steps.

A car's speed changes slowly (at most a few m/s per second), while per-frame ground-plane estimates are
noisy with heavy tails. Each new frame's step is read off a robust (Huber, IRLS) straight line through the
last ``window`` accepted measurements against time, so acceleration from a stop is followed without lag
and single wild measurements are ignored.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from flowvo.odometry.numeric import median

SPEED_WINDOW_S = 0.9  # the robust line's span: nine frames at KITTI's 10 Hz, where it was tuned
MIN_WINDOW = 9  # measurements in the line at least (lower frame rates span more time, as tuned on 5-10 Hz)
SPEED_HORIZON_S = 1.0  # the window's nine frames span 0.9 s at KITTI's 10 Hz; a longer gap ends the history
MAX_ACCELERATION_MPS2 = 9.81  # no car's tyres accelerate or brake it faster (1 g)
RESTART_SPEED_MPS = 3.0  # a car is called still until its flow passes a threshold: it may already be moving
# this fast when the last standstill is seen (synthetic drive 21: 1.8 m/s), or still be when the first one is
MAX_EXTRAPOLATION_S = 0.5  # the line is followed this far past its last measurement, then held: a trend read
# off 0.9 s says nothing of the seconds after it (synthetic 10, a car braking for 2.5 s without a trusted road:
# the line's acceleration extrapolated to 5.5 m per step where the car made 0.4)


def robust_line_value(times_s: np.ndarray, values: np.ndarray, at_s: float, iterations: int = 6) -> float:
    """Value at ``at_s`` of a Huber line fit through (times_s, values) (each iteration's weighted least
    squares in closed form: two unknowns)."""
    offsets = times_s - at_s
    weights = np.ones_like(values)
    value = 0.0
    for _ in range(iterations):
        w = weights * weights
        s0, s1, s2 = w.sum(), w @ offsets, w @ (offsets * offsets)
        b0, b1 = w @ values, w @ (offsets * values)
        determinant = s0 * s2 - s1 * s1
        if determinant > 1e-12 * s0 * s0:
            value, slope = (s2 * b0 - s1 * b1) / determinant, (s0 * b1 - s1 * b0) / determinant
        else:  # all at one time: no slope
            value, slope = b0 / s0, 0.0
        residuals = values - value - slope * offsets
        spread = 1.4826 * median(np.abs(residuals)) + 1e-3
        weights = np.sqrt(np.minimum(1.0, 1.5 * spread / np.maximum(np.abs(residuals), 1e-9)))
    return float(value)


class SpeedPrior:
    """Filters per-frame speed measurements (m/s) into a smooth, outlier-free speed.

    ``update(time_s, speed_mps)`` takes a measurement (None when the frame gave none) and returns the
    filtered speed at ``time_s``; ``stop()`` marks a standstill (the history restarts from zero speed);
    :meth:`could_stand_at` tells whether a car at the last filtered speed can have braked to one.
    Measurements above :meth:`max_speed_at` are rejected as implausible: ``max_speed_mps``, and after a
    standstill what a car can reach since (``RESTART_SPEED_MPS`` + 1 g times the time). Without new
    measurements the line is followed for ``MAX_EXTRAPOLATION_S`` past the last one, then its speed there
    is held. A gap between frames longer than ``horizon_s`` (a paused recording, dropped frames) restarts
    the prior: the speed before it says nothing of the motion over it, so it is never extrapolated across
    (an hour's gap at 11.5 m/s made one 41 km step); the step over the gap is its own measurement, or none.

    The line runs through the last ``MIN_WINDOW`` measurements, or through as many as span ``window_s``
    seconds at the stream's frame rate when that is more (30 frames/s: 27), so a faster camera averages
    over the same time, not over fewer seconds.
    """

    def __init__(self, window_s: float = SPEED_WINDOW_S, min_points: int = 4, max_speed_mps: float = 45.0,
                 horizon_s: float = SPEED_HORIZON_S) -> None:
        self.max_speed_mps = max_speed_mps
        self.min_points = min_points
        self.horizon_s = horizon_s
        self.window_s = window_s
        self._history: deque[tuple[float, float]] = deque(maxlen=MIN_WINDOW)
        self._last_time_s: float | None = None
        self._intervals_s: deque[float] = deque(maxlen=15)
        self._stopped_s: float | None = None  # the last standstill seen
        self._speed: tuple[float, float] | None = None  # the last filtered speed: (time s, m/s)
        self.implausible_measurements = 0  # speeds refused as faster than max_speed_at allows

    def max_speed_at(self, time_s: float) -> float:
        """The highest plausible speed (m/s) at ``time_s``: ``max_speed_mps``, or less soon after a
        standstill (a car pulling away gains at most 1 g; a plane ten times too far put a step at 40 m/s 0.7
        s after one)."""
        if self._stopped_s is None:
            return self.max_speed_mps
        return min(self.max_speed_mps, RESTART_SPEED_MPS + MAX_ACCELERATION_MPS2 * (time_s - self._stopped_s))

    def could_stand_at(self, time_s: float) -> bool:
        """Whether a car at the last filtered speed can stand still at ``time_s``: braking at 1 g, it is
        down to ``RESTART_SPEED_MPS`` by then (images with only distant scenery move as little as a standing
        car's: past a crest at 12 m/s, synthetic). The speed is the one the prior last gave, held or
        measured: the method does not stop a car it still takes to be fast."""
        if self._speed is None:
            return True
        speed_time_s, speed_mps = self._speed
        return speed_mps - MAX_ACCELERATION_MPS2 * (time_s - speed_time_s) <= RESTART_SPEED_MPS

    @property
    def last_speed_mps(self) -> float | None:
        """The speed the prior last gave (m/s; 0 after a standstill), or None before any."""
        return None if self._speed is None else self._speed[1]

    def update(self, time_s: float, speed_mps: float | None) -> float | None:
        """The filtered speed (m/s) at ``time_s``, or None while there is no measurement at all."""
        speed = self._filtered(time_s, speed_mps)
        self._speed = None if speed is None else (time_s, speed)
        return speed

    def _filtered(self, time_s: float, speed_mps: float | None) -> float | None:
        """:meth:`update`'s filtered speed, before it is remembered for :meth:`could_stand_at`."""
        plausible = speed_mps is not None and 0.0 <= speed_mps <= self.max_speed_at(time_s)
        self.implausible_measurements += speed_mps is not None and not plausible
        gap = self._last_time_s is not None and time_s - self._last_time_s > self.horizon_s
        if self._last_time_s is not None and not gap:
            self._fit_window(time_s - self._last_time_s)
        self._last_time_s = time_s
        if gap:  # a mean speed over the gap is no car's speed: used for this step, kept out of the history
            self._history.clear()
            return speed_mps if plausible else None
        if plausible:
            self._history.append((time_s, speed_mps))
        if not self._history:
            return None
        times, speeds = (np.array(column) for column in zip(*self._history, strict=True))
        if len(speeds) < self.min_points:
            return median(speeds)
        return max(0.0, robust_line_value(times, speeds, min(time_s, times[-1] + MAX_EXTRAPOLATION_S)))

    def _fit_window(self, interval_s: float) -> None:
        """Size the history to span ``window_s`` at the recent frame interval (never below MIN_WINDOW)."""
        self._intervals_s.append(interval_s)
        size = max(MIN_WINDOW, int(round(self.window_s / median(self._intervals_s))))
        if size != self._history.maxlen:
            self._history = deque(self._history, maxlen=size)

    def stop(self, time_s: float) -> None:
        """A standstill at ``time_s``: earlier speeds no longer describe the motion."""
        self._history.clear()
        self._history.append((time_s, 0.0))
        self._last_time_s = self._stopped_s = time_s
        self._speed = (time_s, 0.0)
