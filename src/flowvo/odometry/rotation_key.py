"""Rotations measured over up to 0.1 s: a rotation key frame for frame rates above 13 Hz.

Each Lucas-Kanade track carries an error of its own that does not shrink with the motion, so a rotation
chained from pairs drifts with the number of steps, not with the distance: on one synthetic drive (exact
truth, 189 m) the default method's r_err was 0.0129 deg/m at 30 frames/s against 0.0052 at 10. Here a step's
rotation is the rotation fitted from a key frame to this frame after the one from the key frame to the
previous frame, so the errors of the fits within a key frame's span do not add up: 0.0050 deg/m at
30 frames/s. A key frame is kept while younger than ``min_span_s``; at 10 frames/s and below every step is
longer, the key frame is always the previous frame and nothing changes.

Rotations are ``R_next_prev`` (a point X in the earlier camera's frame is ``R X`` in the later one's); times
in seconds.
"""

from __future__ import annotations

from typing import Generic, TypeVar

import numpy as np

MIN_SPAN_S = 0.075  # a key frame younger than this is kept: three quarters of KITTI's 0.1 s frame interval (the one
# the default method was measured at), so a 10 Hz camera's timestamp jitter never keeps one; 20 and 30 frames/s
# then measure each rotation over up to 0.1 s

Frame = TypeVar("Frame")


class RotationKeyFrame(Generic[Frame]):
    """The rotation key frame of a stream of steps (module docstring): ``frame`` is where the next step's
    rotation is measured from (None: the previous frame)."""

    def __init__(self, min_span_s: float = MIN_SPAN_S) -> None:
        self.min_span_s = min_span_s
        self.frame: Frame | None = None
        self._time_s = 0.0
        self._R_key_previous = np.eye(3)  # the key frame's rotation to the previous frame

    def step_rotation(self, R_key_current: np.ndarray) -> np.ndarray:
        """This step's rotation ``R_current_previous`` from the key frame's fitted rotation to the current frame."""
        return R_key_current @ self._R_key_previous.T

    def advance(self, previous: tuple[float, Frame], time_s: float, R_step: np.ndarray) -> None:
        """After the step from ``previous`` (its time, s, and frame) to the frame at ``time_s`` with the final
        rotation ``R_step`` (``R_current_previous``): the key frame (the previous frame when there was none)
        stays while it is younger than ``min_span_s``, else the next step is measured from the current frame."""
        if self.frame is None:
            self._time_s, self.frame = previous
        if time_s - self._time_s < self.min_span_s:
            self._R_key_previous = R_step @ self._R_key_previous
        else:
            self.forget()

    def forget(self) -> None:
        """No key frame: the next step is measured from its previous frame (after a standstill or a step
        without a fit)."""
        self.frame, self._R_key_previous = None, np.eye(3)
