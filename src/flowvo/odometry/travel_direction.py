"""The direction of travel of a car at speed, to refuse a fitted direction no car can have taken.

A car moves along its own axis. A camera fixed on it, ``L`` ahead of the rear axle, sees its direction of
travel turn away from its forward axis by about ``L * yaw_rate / speed`` (plus half the step's yaw), and a
car's lateral acceleration ``speed * yaw_rate`` stays under about 8 m/s^2: from 6 m/s on, with ``L`` up to
1.5 m, the direction of travel stays within 20 degrees of the camera's forward axis (within 11 at 8 m/s).
Slower, a turning camera swings further (synthetic replay 08's start, turning at 2-4 m/s: 40-80 degrees),
and no direction is checked. At speed, where the view holds only distant scenery (past a crest) the
essential fit's direction is noise, sideways or backwards; such a direction is refused and the last one
taken at speed is used instead (the forward axis before any). Directions are unit 3-vectors in the camera
frame of the step's first frame (x right, y down, z forward).
"""

from __future__ import annotations

import numpy as np

MAX_ANGLE_DEG = 20.0  # from the camera's forward axis, at speed
MIN_SPEED_MPS = 6.0  # from this speed on a car's direction of travel stays within MAX_ANGLE_DEG (docstring)


class TravelDirection:
    """The check of each fitted direction of travel against the camera's forward axis (module docstring)."""

    def __init__(self, forward: np.ndarray, max_angle_deg: float = MAX_ANGLE_DEG,
                 min_speed_mps: float = MIN_SPEED_MPS) -> None:
        self.forward = np.asarray(forward, dtype=float) / np.linalg.norm(forward)
        self.min_cosine = float(np.cos(np.radians(max_angle_deg)))
        self.min_speed_mps = min_speed_mps
        self.last_taken = self.forward  # the last direction taken at speed
        self.kept_steps = 0  # steps whose fitted direction was refused

    def checked(self, direction: np.ndarray, speed_mps: float | None) -> np.ndarray:
        """The direction of travel to take for a step whose fit gave ``direction`` (unit) with the car at
        ``speed_mps`` (m/s; None: not known): that one, or the last one taken at speed when the car is fast
        and ``direction`` lies more than the limit off the forward axis."""
        if speed_mps is None or speed_mps < self.min_speed_mps:
            return direction
        if float(direction @ self.forward) >= self.min_cosine:
            self.last_taken = direction
            return direction
        self.kept_steps += 1
        return self.last_taken
