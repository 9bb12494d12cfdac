"""The direction of travel of a car, to refuse a fitted direction no car can have taken.

A car moves along its own axis. A camera fixed on it, ``L`` ahead of the rear axle, sees its direction of
travel turn away from its forward axis by about ``L * yaw_rate / speed`` (plus half the step's yaw), and a
car's lateral acceleration ``speed * yaw_rate`` stays under about 8 m/s^2: from 6 m/s on, with ``L`` up to
1.5 m, the direction of travel stays within 20 degrees of the camera's forward axis (within 11 at 8 m/s).
Slower, a turning camera swings further (synthetic replay 08's start, turning at 2-4 m/s: 40-80 degrees).
At speed, where the view holds only distant scenery (past a crest) the essential fit's direction is noise,
sideways or backwards; such a direction is refused and the last one taken at speed is used instead (the
forward axis before any).

At any speed both parts of that angle lie on the side the car turns to (a camera ahead of the rear axle: KITTI's
ground truth reads ``L`` 0.85-0.99 m on 00, 03, 05, 07 and 08). A direction further than ``MAX_AGAINST_TURN_DEG``
against the step's turn is a failed fit: near a wall that fills the view, the fit's yaw trades against a sideways
direction (a synthetic replay of KITTI 03, turning at 2.5 m/s toward a facade 8 m ahead: steps 0.8 degrees too far,
their directions 22-35 degrees against the turn, 9 degrees of yaw lost in 20 steps). It is refused for the last
direction taken at any speed.

Up and down, a car's direction of travel follows its road: from one step to the next it turns by the road's change
of grade and the body's pitching, a degree or two. A fitted direction whose elevation lies more than
``MAX_ELEVATION_JUMP_DEG`` from that of the directions taken over the last steps is a failed fit too: where a wall
fills the view, the fit's pitch trades against an elevation as its yaw trades against a sideways direction (the same
replay's turn in another world: directions 5-10 degrees too low, each with a pitch 0.16-0.25 degrees too far up, 2
degrees of pitch in 25 steps). It is refused for the last direction taken at any speed. Measured against the recent
directions, not the car's axes, the check holds for a camera whose mounting is not known yet.

Directions are unit 3-vectors in the camera frame of the step's first frame (x right, y down, z forward); yaws in
radians, positive to the right.
"""

from __future__ import annotations

import statistics
from collections import deque

import numpy as np

MAX_ANGLE_DEG = 20.0  # from the camera's forward axis, at speed
MIN_SPEED_MPS = 6.0  # from this speed on a car's direction of travel stays within MAX_ANGLE_DEG (docstring)
MAX_AGAINST_TURN_DEG = 10.0  # a direction of travel further against its step's turn is a failed fit (docstring): of
# the 8304 steps of KITTI's ground truth 00-10 that turn MIN_TURN_DEG or more, 8 lie further against it (00 and 02,
# turning 1.6-3.7 degrees a step at 3.8-5.6 m/s), none of the real clips' own steps more than 3
MIN_TURN_DEG = 0.3  # a step that turns less has no side for its direction of travel to lie on
MAX_ELEVATION_JUMP_DEG = 5.0  # a direction of travel further up or down from the recent ones is a failed fit
# (docstring): of the 18895 steps of KITTI's ground truth 00-07, 09 and 10 (08 starts by climbing 1.85 m/s, an error of
# its truth), 17 lie further from the median of their last ELEVATION_STEPS, none of the real clips' own steps
ELEVATION_STEPS = 9  # the directions taken last whose median elevation a new one is held to
MAX_ELEVATION_JUMP_RAD = float(np.radians(MAX_ELEVATION_JUMP_DEG))


class TravelDirection:
    """The checks of each fitted direction of travel: against its step's turn, its elevation against the recent
    directions', and at speed against the camera's forward axis (module docstring)."""

    def __init__(self, forward: np.ndarray, right: np.ndarray, max_angle_deg: float = MAX_ANGLE_DEG,
                 min_speed_mps: float = MIN_SPEED_MPS) -> None:
        self.turn(forward, right)
        self.min_cosine = float(np.cos(np.radians(max_angle_deg)))
        self.min_speed_mps = min_speed_mps
        self.last_taken = self.forward  # the last direction taken at speed
        self.last_any = self.forward  # the last direction taken at any speed
        self.kept_steps = 0  # steps whose fitted direction was refused at speed, off the forward axis
        self.against_turn_steps = 0  # steps whose fitted direction was refused against their turn
        self.elevation_jump_steps = 0  # steps whose fitted direction was refused for its elevation
        self._recent: deque[np.ndarray] = deque(maxlen=ELEVATION_STEPS)  # the directions taken last

    def turn(self, forward: np.ndarray, right: np.ndarray) -> None:
        """The car's forward and right axes are now ``forward`` and ``right`` (camera frame, any length)."""
        self.forward = np.asarray(forward, dtype=float) / np.linalg.norm(forward)
        self.right = np.asarray(right, dtype=float) / np.linalg.norm(right)
        self._up = np.cross(self.right, self.forward)  # x right, y down, z forward: right x forward points up

    def checked(self, direction: np.ndarray, speed_mps: float | None, yaw_rad: float = 0.0) -> np.ndarray:
        """The direction of travel to take for a step turning ``yaw_rad`` (0: not turning) whose fit gave
        ``direction`` (unit) with the car at ``speed_mps`` (m/s; None: not known): that one; the last one taken when
        ``direction`` lies more than ``MAX_AGAINST_TURN_DEG`` against the turn or its elevation more than
        ``MAX_ELEVATION_JUMP_DEG`` from the recent directions'; the last one taken at speed when the car is fast and
        ``direction`` lies more than the limit off the forward axis."""
        if self._against_turn(direction, yaw_rad):
            self.against_turn_steps += 1
            return self.last_any
        if self._elevation_jumped(direction):
            self.elevation_jump_steps += 1
            return self.last_any
        fast = speed_mps is not None and speed_mps >= self.min_speed_mps
        if fast and float(direction @ self.forward) < self.min_cosine:
            self.kept_steps += 1
            return self.last_taken
        if fast:
            self.last_taken = direction
        self.last_any = direction
        self._recent.append(direction)
        return direction

    def _elevation_jumped(self, direction: np.ndarray) -> bool:
        """Whether ``direction``'s elevation above the car's plane of its forward and right axes lies more than
        ``MAX_ELEVATION_JUMP_DEG`` from the median of the last ``ELEVATION_STEPS`` directions taken (three at least)."""
        if len(self._recent) < 3:
            return False
        elevations_rad = np.arcsin(np.clip(np.array((*self._recent, direction)) @ self._up, -1.0, 1.0)).tolist()
        return abs(elevations_rad[-1] - statistics.median(elevations_rad[:-1])) > MAX_ELEVATION_JUMP_RAD

    def _against_turn(self, direction: np.ndarray, yaw_rad: float) -> bool:
        """Whether ``direction`` lies more than ``MAX_AGAINST_TURN_DEG`` to the other side than a step turning
        ``yaw_rad`` (``MIN_TURN_DEG`` or more) turns to, about the car's vertical axis."""
        if abs(yaw_rad) < np.radians(MIN_TURN_DEG):
            return False
        side_rad = np.arctan2(float(direction @ self.right), float(direction @ self.forward))
        return side_rad * np.sign(yaw_rad) < -np.radians(MAX_AGAINST_TURN_DEG)
