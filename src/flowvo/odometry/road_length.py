"""A step's metric length from the road: the road points triangulated into a plane, gated, its normal blended
over many steps and its distance taken under the car (:class:`flowvo.odometry.road_normal.RoadNormal`), and the
camera height over that distance.

Frames: the camera frame of the road key frame (x right, y down, z forward); pixels undistorted working pixels;
lengths in metres.
"""

from __future__ import annotations

import numpy as np

from flowvo.camera import mounting_of_road_normal, mounting_rotation
from flowvo.odometry.road_noise import RoadFlowNoise
from flowvo.odometry.road_normal import RoadNormal
from flowvo.odometry.road_plane import RoadPlane, in_camera_frame
from flowvo.odometry.road_profile import RoadProfile, road_residuals
from flowvo.odometry.road_scale import near_of, road_points, trusted_plane_among
from flowvo.odometry.road_tally import RoadPlaneTally
from flowvo.odometry.two_view import EssentialMotion, translation_parallax_px


class RoadLength:
    """The road scale of a camera with intrinsics ``K`` (working pixels), ``camera_height_m`` above the road,
    pitched ``pitch_deg`` down and then rolled ``roll_deg`` (degrees, :func:`flowvo.camera.mounting_rotation`; its
    road planes are judged in the road-levelled frame); ``min_parallax_px``: the road motion beyond the rotation that
    nine road points in ten must show.

    Where the drive's candidate planes say the camera is pitched or rolled otherwise (most refused as tilted, leaning
    alike by a degree or more: :meth:`RoadPlaneTally.mounting_hint_deg`), their median pitch and roll are taken from
    the next step on, the road's normal carried so far is dropped, and the candidates after it judge them again (a
    fixed point: a camera pitched 8 degrees down and run as if level is levelled once, then its candidates centre on
    the road; a pitch taken from a long tilt ahead is taken back by the level road after it). ``pitches_taken_deg``,
    ``rolls_taken_deg``: the mountings so taken (degrees, :func:`flowvo.camera.mounting_rotation`)."""

    def __init__(self, K: np.ndarray, camera_height_m: float, pitch_deg: float, roll_deg: float,
                 min_parallax_px: float) -> None:
        self.K, self.camera_height_m, self.pitch_deg, self.roll_deg = K, camera_height_m, pitch_deg, roll_deg
        self.levelling = mounting_rotation(pitch_deg, roll_deg) if pitch_deg or roll_deg else None
        self.pitches_taken_deg: list[float] = []
        self.rolls_taken_deg: list[float] = []
        self.min_parallax_px = min_parallax_px
        self.normal = RoadNormal()
        self.tally = RoadPlaneTally()
        self.profile = RoadProfile()
        self.noise = RoadFlowNoise()
        self.near_parallax_px = 0.0  # the last step's near road motion beyond the rotation since the key frame
        # (pixels; its plane trusted or refused; 0: no fit)

    def advance(self, R_next_prev: np.ndarray, dt_s: float, step_m: float) -> None:
        """Carry the road's normal over a step of ``dt_s`` seconds and about ``step_m`` metres with rotation
        ``R_next_prev``."""
        self.normal.advance(R_next_prev, dt_s, step_m)

    def forget(self) -> None:
        """No rotation was measured: the next plane starts afresh."""
        self.normal.forget()

    def measure(self, road: tuple[np.ndarray, np.ndarray], key_fit: EssentialMotion | None, measured: bool,
                baseline_shares: np.ndarray | None = None) -> tuple[RoadPlane | None, float | None]:
        """The trusted road plane (its normal blended, :meth:`RoadNormal.smoothed`; ``measured``: the flow was
        within reach, so the blend is carried on) of the road correspondences ``road`` (key frame, current frame)
        under the key frame's motion ``key_fit``, and the metres travelled since the key frame; (None, None)
        without a fit or a trusted plane. ``baseline_shares`` (N,): each point's baseline over the span's (a rolling
        shutter's, :func:`flowvo.odometry.rolling_shutter.baseline_shares`; None: a global shutter's, all one). A
        trusted plane's points tell ``noise`` how far the road flow errs
        (:class:`flowvo.odometry.road_noise.RoadFlowNoise`)."""
        self.near_parallax_px = 0.0
        if key_fit is None or not len(road[0]):
            return None, None
        parallax_px = translation_parallax_px(road[0], road[1], self.K, key_fit.R)
        near_px = self.near_parallax_px = near_of(parallax_px)  # whether or not its plane is trusted
        if near_px < self.min_parallax_px:  # the road's flow is lost: no depth to triangulate
            return None, None
        points = road_points(road[0], road[1], self.K, key_fit, levelling=self.levelling)
        if points is not None and baseline_shares is not None:
            points = points * baseline_shares[:, None]  # each point's distance from the camera scales with its baseline
        plane = None if points is None else trusted_plane_among(points, tally=self.tally, profile=self.profile)
        if plane is not None:  # the ground beside the road learns from the trusted plane's points
            residuals = road_residuals(points, plane)
            self.profile.observe(points, plane, residuals)
        levelling = self.levelling  # the frame the points and the plane are in (a mounting taken below changes it)
        self._level_by_the_drive()
        if plane is None:
            return None, None
        self.noise.observe(residuals, parallax_px)  # and so does the flow's noise
        plane = self.normal.smoothed(in_camera_frame(plane, levelling), key_fit.R, keep=measured,
                                     camera_height_m=self.camera_height_m)
        return plane, self.camera_height_m / plane.distance

    def _level_by_the_drive(self) -> None:
        """Take the pitch and roll the candidate planes agree on (see the class docstring): the road's normal they
        lean to, in the camera's frame, read as a mounting."""
        hint_deg = self.tally.mounting_hint_deg()
        if hint_deg is None:
            return
        pitch, roll = np.radians(hint_deg)
        leaning = np.array([np.tan(roll), 1.0, np.tan(pitch)])  # the tally's angles: atan2(z, y) and atan2(x, y)
        levelling = np.eye(3) if self.levelling is None else self.levelling
        self.pitch_deg, self.roll_deg = mounting_of_road_normal(levelling.T @ (leaning / np.linalg.norm(leaning)))
        self.levelling = mounting_rotation(self.pitch_deg, self.roll_deg)
        self.pitches_taken_deg.append(round(self.pitch_deg, 2))
        self.rolls_taken_deg.append(round(self.roll_deg, 2))
        self.tally.restart()
        self.profile.forget()  # its cells were judged in the frame before
        self.noise.forget()  # its planes' residuals too
        self.normal.forget()  # the road's normal carried from before leaned by the mounting just taken
