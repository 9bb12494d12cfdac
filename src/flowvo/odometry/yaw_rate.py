"""A car's yaw rate changes smoothly: a fitted rotation whose yaw rate jumps further from the last step's
than a car can turn its wheel is refused for the last yaw rate taken.

At low speed the essential fit's yaw trades against a sideways direction of travel, and now and then it
picks the wrong pair: on the synthetic replay of KITTI 08 single steps at 0.7-3 m/s (and three at 6 m/s in
a turn) turned 0.3-1.4 degrees too far while their neighbours were within 0.05 degrees of the truth. A car's
yaw rate changes at most by about 60 deg/s^2 times the step's duration: KITTI's ground truth 01-10 (10 Hz)
changes its yaw by at most 0.12-0.76 degrees from one step to the next (99.9th percentiles 0.12-0.45; 00 has
seven steps of 0.6-2.5), so a change of more than ``60 deg/s^2 * dt^2`` (0.6 degrees at 10 Hz) is taken for a
failed fit. Such a step takes the last yaw rate taken (its whole rotation, at that rate); where the next
step's rate agrees with the refused one rather than with the last taken, the change was real (it held), and
that rate is taken from then on. At high frame rates the steps' own scatter sets the bound instead
(``min_change_deg``). Only below 6 m/s: faster, the fit's yaw is well conditioned and the direction of travel
is checked instead (:mod:`flowvo.odometry.travel_direction`), and a synthetic path may turn faster than a car (the
demo's drive, at 13 m/s, straightens out of a 1 g curve by 1.2 degrees a step: checked at that speed it scored
1.92 against 0.96 %). Rotations are rotation vectors in the camera frame (x right, y down, z forward),
radians.
"""

from __future__ import annotations

import numpy as np

from flowvo.odometry.travel_direction import MIN_SPEED_MPS as DIRECTION_CHECKED_FROM_MPS

MAX_YAW_ACCELERATION_DEG_S2 = 60.0  # module docstring: 0.6 degrees a step at 10 Hz
MAX_SPEED_MPS = DIRECTION_CHECKED_FROM_MPS  # checked below the speed from which the direction is (6 m/s)
MIN_YAW_CHANGE_DEG = 0.2  # a step's yaw change never refused below this: at 30 frames/s the bound above is
# 0.07 degrees, within the fits' own scatter (generated drive at 30 frames/s: r_err 0.0050 -> 0.0060 deg/m
# without this floor)


class YawRateCheck:
    """The check of each step's rotation against the last yaw rate taken (module docstring). ``up``: the
    car's vertical axis in the camera frame (unit; the camera's y axis for a camera mounted level)."""

    def __init__(self, up: np.ndarray, max_acceleration_deg_s2: float = MAX_YAW_ACCELERATION_DEG_S2,
                 min_change_deg: float = MIN_YAW_CHANGE_DEG, max_speed_mps: float = MAX_SPEED_MPS) -> None:
        self.up = np.asarray(up, dtype=float) / np.linalg.norm(up)
        self.max_speed_mps = max_speed_mps
        self.max_acceleration_rad_s2 = np.radians(max_acceleration_deg_s2)
        self.min_change_rad = np.radians(min_change_deg)
        self.taken_rate: np.ndarray | None = None  # rad/s, the last rotation rate taken
        self.refused_rate: np.ndarray | None = None  # rad/s, the last step's, where it was refused
        self.refused_steps = 0

    def checked(self, rotation: np.ndarray, dt_s: float, speed_mps: float | None) -> np.ndarray:
        """The rotation vector (rad) to take for a step of ``dt_s`` seconds whose fit gave ``rotation``, the car
        at ``speed_mps`` (m/s; None: not known): that one, or, below ``max_speed_mps`` or at an unknown speed,
        the last rate taken over ``dt_s`` where the yaw rate jumped beyond the bound."""
        rate = rotation / dt_s
        refused, self.refused_rate = self.refused_rate, None
        fast = speed_mps is not None and speed_mps >= self.max_speed_mps
        if fast or self.taken_rate is None or not self._jumps(rate, self.taken_rate, dt_s) or (
                refused is not None and not self._jumps(rate, refused, dt_s)):
            self.taken_rate = rate
            return rotation
        self.refused_rate = rate
        self.refused_steps += 1
        return self.taken_rate * dt_s

    def took(self, rotation: np.ndarray, dt_s: float) -> None:
        """The rotation vector (rad) the step of ``dt_s`` seconds finally took, where a later check fitted it again
        (:mod:`flowvo.odometry.travel_direction`): the rate the next step is checked against. Without it a fit
        refused for
        its direction at speed left its wrong yaw rate behind, and the next, slower step's good fit was refused
        against it (synthetic replay 08, frame 495: 2.2 degrees of yaw off for the rest of the drive)."""
        self.taken_rate = rotation / dt_s

    def forget(self) -> None:
        """No rotation was measured (a standstill, a degenerate step): the next one is taken as it comes."""
        self.taken_rate, self.refused_rate = None, None

    def _jumps(self, rate: np.ndarray, reference: np.ndarray, dt_s: float) -> bool:
        change_rad = abs(float((rate - reference) @ self.up)) * dt_s
        return change_rad > max(self.max_acceleration_rad_s2 * dt_s**2, self.min_change_rad)
