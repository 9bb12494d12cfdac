"""A step's motion up to scale, checked against what a car can do: its rotation measured from the rotation key
frame where there is one (:mod:`flowvo.odometry.rotation_key`), a yaw rate that jumped refused below 6 m/s
(:mod:`flowvo.odometry.yaw_rate`), a direction of travel against the step's turn refused, one whose elevation jumped
from the recent directions' refused, and one too far off the car's axis refused at speed
(:mod:`flowvo.odometry.travel_direction`).

Tracks are undistorted working pixels (N, 2); rotations ``R_next_prev``; times in seconds; speeds in m/s.
"""

from __future__ import annotations

from typing import Generic, TypeVar

import numpy as np

from flowvo.geometry import so3_exp, so3_log
from flowvo.odometry.rotation_key import RotationKeyFrame
from flowvo.odometry.travel_direction import TravelDirection
from flowvo.odometry.two_view import EssentialMotion, direction_given_rotation, motion_along
from flowvo.odometry.yaw_rate import YawRateCheck

MAX_KEY_ROTATION_OFF_DEG = 0.5  # a step rotation from the rotation key frame further off the pair's is a failed fit
# (the pair's rotations are 0.005-0.015 degrees off the truth, rms, on the synthetic drives)

Frame = TypeVar("Frame")


class MotionChecks(Generic[Frame]):
    """The checks of a stream of steps (module docstring) for a camera with intrinsics ``K`` whose car's axes
    are the columns of ``car_axes`` (right, down, forward in the camera frame); ``threshold_px``: the tracks'
    inlier threshold for a rotation fitted again along a direction."""

    def __init__(self, K: np.ndarray, car_axes: np.ndarray, threshold_px: float) -> None:
        self.K, self.threshold_px = K, threshold_px
        self.travel = TravelDirection(car_axes[:, 2], car_axes[:, 0])  # along the road
        self.yaw_rate = YawRateCheck(car_axes[:, 1])  # yaw turns about the car's vertical axis
        self.rotation_key: RotationKeyFrame[Frame] = RotationKeyFrame()
        self.rotation_key_steps = 0  # steps whose rotation was measured from an earlier key frame

    def turn_car_axes(self, car_axes: np.ndarray) -> None:
        """The car's axes are now the columns of ``car_axes`` (the camera's pitch was taken from the drive)."""
        self.travel.turn(car_axes[:, 2], car_axes[:, 0])
        self.yaw_rate.up = car_axes[:, 1] / np.linalg.norm(car_axes[:, 1])

    def forget(self) -> None:
        """No motion was measured (a standstill, a step without a fit): the next step starts afresh."""
        self.rotation_key.forget()
        self.yaw_rate.forget()

    def checked(self, fit: EssentialMotion, key_fit: EssentialMotion | None, tracks: tuple[np.ndarray, np.ndarray],
                dt_s: float, last_speed_mps: float | None) -> EssentialMotion:
        """The step's motion of ``dt_s`` from the pair's ``fit`` to its ``tracks`` (previous, current) and, where
        the rotation key frame is earlier than the previous frame, ``key_fit``, the fit of its tracks into the
        current frame (None: no key frame, or no fit)."""
        if key_fit is not None:
            fit = self._over_rotation_key(fit, key_fit, tracks)
        yaw_checked = self._yaw_checked(fit, tracks, dt_s, last_speed_mps)
        fit = self._travel_checked(yaw_checked, tracks, last_speed_mps)
        if fit is not yaw_checked:
            self.yaw_rate.took(so3_log(fit.R), dt_s)
        return fit

    def advance(self, previous: tuple[float, Frame], time_s: float, R_step: np.ndarray) -> None:
        """After the step from ``previous`` (its time and frame) to ``time_s`` with the final rotation ``R_step``."""
        self.rotation_key.advance(previous, time_s, R_step)

    def _over_rotation_key(self, fit: EssentialMotion, key_fit: EssentialMotion,
                           tracks: tuple[np.ndarray, np.ndarray]) -> EssentialMotion:
        """The step's motion with its rotation measured from the rotation key frame and its direction fitted
        again under that rotation to the pair's inlier tracks; the pair's ``fit`` where that rotation lies over
        ``MAX_KEY_ROTATION_OFF_DEG`` off the pair's."""
        R = self.rotation_key.step_rotation(key_fit.R)
        if np.degrees(np.linalg.norm(so3_log(R @ fit.R.T))) > MAX_KEY_ROTATION_OFF_DEG:
            return fit
        self.rotation_key_steps += 1
        return self._under_rotation(fit, R, tracks)

    def _under_rotation(self, fit: EssentialMotion, R: np.ndarray, tracks: tuple[np.ndarray, np.ndarray]
                        ) -> EssentialMotion:
        """The step's motion with rotation ``R`` and the direction fitted again under it to the pair's inlier
        tracks of ``fit`` (:func:`direction_given_rotation`)."""
        inliers = fit.inliers
        return EssentialMotion(R, direction_given_rotation(tracks[0][inliers], tracks[1][inliers], self.K, R,
                                                           fit.t_dir), inliers)

    def _travel_checked(self, fit: EssentialMotion, tracks: tuple[np.ndarray, np.ndarray],
                        last_speed_mps: float | None) -> EssentialMotion:
        """The fit, or, where its direction of travel lies against its turn, jumped up or down from the recent ones, or
        lies further off the forward axis than a fast car's can (:class:`TravelDirection`), the motion along the
        direction taken instead with its rotation fitted again to the tracks (:func:`motion_along`: the fit's rotation
        came with its wrong direction; kept where no rotation along that direction explains 30 tracks)."""
        direction = -fit.R.T @ fit.t_dir  # of travel, in the first frame of the step
        yaw_rad = -float(so3_log(fit.R) @ self.yaw_rate.up)  # positive to the right: R is R_next_prev
        taken = self.travel.checked(direction, last_speed_mps, yaw_rad)
        if taken is direction:
            return fit
        along = motion_along(tracks[0], tracks[1], self.K, taken, fit.R, self.threshold_px)
        return along if along is not None else EssentialMotion(fit.R, -fit.R @ taken, fit.inliers)

    def _yaw_checked(self, fit: EssentialMotion, tracks: tuple[np.ndarray, np.ndarray], dt_s: float,
                     last_speed_mps: float | None) -> EssentialMotion:
        """The fit, or, where its yaw rate jumped further from the last one taken than a car's can below 6 m/s
        (a failed fit), the last yaw rate's rotation with the direction fitted again under it."""
        rotation = so3_log(fit.R)
        taken = self.yaw_rate.checked(rotation, dt_s, last_speed_mps)
        return fit if taken is rotation else self._under_rotation(fit, so3_exp(taken), tracks)

    def summary(self) -> dict:
        """How many steps each check changed."""
        return {"direction_kept_steps": self.travel.kept_steps,
                "direction_against_turn_steps": self.travel.against_turn_steps,
                "direction_elevation_steps": self.travel.elevation_jump_steps,
                "yaw_refused_steps": self.yaw_rate.refused_steps,
                "rotation_key_steps": self.rotation_key_steps}
