"""``flowvo.Pose``: one final camera pose and how its step was measured."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flowvo.methods.base import OdometryStep
from flowvo.odometry.scale_window import StepRecord


@dataclass(frozen=True)
class Pose:
    """The camera's pose at frame ``frame`` (0-based, in the order pushed or read), taken at ``time_s`` (seconds).

    ``T_world_cam`` (4, 4): camera-to-world, the world being the first frame's camera frame (x right, y down,
    z forward; metres), as a KITTI pose file holds it. ``T_prev_cur`` (4, 4): the step from the previous frame's
    camera (the identity for frame 0). ``length_m``: the step's length (metres; 0 for frame 0).
    ``length_log_sigma``: the standard deviation of the step length's natural log (0.01 is 1 %; None where the
    method gives none: standstills, steps nothing measured, methods without a scale window) and ``measured_by``:
    what measured the step ("+"-joined from road, ratio and network; "none"; "standstill"; None for frame 0 and
    for methods without a scale window), as ``NAME_steps.csv`` has them.
    """

    frame: int
    time_s: float
    T_world_cam: np.ndarray
    T_prev_cur: np.ndarray
    length_log_sigma: float | None = None
    measured_by: str | None = None

    @property
    def length_m(self) -> float:
        """The step's length, metres (0 for the first frame)."""
        return float(np.linalg.norm(self.T_prev_cur[:3, 3]))

    @property
    def position_m(self) -> np.ndarray:
        """The camera centre (3,) in the world frame, metres."""
        return self.T_world_cam[:3, 3].copy()

    @property
    def R_world_cam(self) -> np.ndarray:
        """The camera's orientation (3, 3) in the world frame."""
        return self.T_world_cam[:3, :3].copy()

    def __repr__(self) -> str:
        x, y, z = self.T_world_cam[:3, 3]
        sigma = "" if self.length_log_sigma is None else f", length_log_sigma={self.length_log_sigma:.4f}"
        measured = "" if self.measured_by is None else f", measured_by={self.measured_by!r}"
        return (f"Pose(frame={self.frame}, time_s={self.time_s:.6f}, position_m=({x:.3f}, {y:.3f}, {z:.3f}), "
                f"length_m={self.length_m:.4f}{sigma}{measured})")


class StepRecords:
    """The step records of a method (:meth:`OdometryStep.step_records`) looked up by the time of each final motion,
    in order (a record is made when the scale window finalises its step, no later than the motion comes out)."""

    def __init__(self, step: OdometryStep) -> None:
        self.step = step
        self.next = 0

    def of(self, time_s: float) -> StepRecord | None:
        """The record of the step ending at ``time_s``; None for a method without records."""
        records = self.step.step_records()
        if records is None:
            return None
        for index in range(self.next, len(records)):
            if records[index].time_s == time_s:
                self.next = index + 1
                return records[index]
        return None


def make_pose(frame: int, time_s: float, T_world_cam: np.ndarray, T_prev_cur: np.ndarray | None,
              record: StepRecord | None) -> Pose:
    """The :class:`Pose` of a final motion (``T_prev_cur`` None: the first frame) and its step record."""
    motion = np.eye(4) if T_prev_cur is None else np.array(T_prev_cur, dtype=np.float64)
    return Pose(frame, float(time_s), np.array(T_world_cam, dtype=np.float64), motion,
                None if record is None else record.log_sigma, None if record is None else record.measured_by)
