"""The road's normal in the camera frame, blended over the trusted road planes and carried by the camera's rotation
(a scalar Kalman filter) and by the road's vertical curve, and the road plane's distance taken under the car (the
road's normal there and its curve up to the plane's centre).

Angles in radians; planes in the camera frame, distances in units of the step; places along the drive in metres.
"""

from __future__ import annotations

import math

import numpy as np

from flowvo.camera import mounting_of_road_normal
from flowvo.odometry.road_plane import RoadPlane

FIT_PITCH_SIGMA_RAD = 0.005  # a plane's normal from one step of road, its centre 7.4 step lengths ahead (real
# clip 06 at 1.2 m a step: fitted pitch scatters by 0.25 deg, real pitching included); it grows with the square
# of the depth's ratio to the baseline, as the heights it is fitted to do
FIT_REFERENCE_DEPTH = 7.4  # step lengths
GRADE_DRIFT_RAD = 0.0035  # per square-root second: how fast the road's normal may change beyond the camera's
# rotation (grade, pitching); with FIT_PITCH_SIGMA_RAD it gives a new plane at 7.4 step lengths weight 0.2 at 10 Hz
CURVE_WEIGHT = 0.1  # the weight of each trusted plane's vertical curve in the running estimate (about twenty planes)
BEHIND_M = 20.0  # the normals of the road ahead are kept until the car is this far past their place (a road key
# frame up to 0.5 s back at 40 m/s)


class RoadNormal:
    """The road's normal in the camera frame, smoothed over the trusted road planes, and the road under the car.

    One step's fit tilts its plane about the centre of its near road points: a pitch error of 1 degree moves
    the plane's distance under the camera by 3.5-7.5 % (real clips), and its fitted pitch scatters by
    0.3-0.7 degrees. The road's normal in the camera frame changes only as the camera turns, which the
    tracked points measure far better, and as the road's grade changes, slowly. So the normal is carried
    from frame to frame by the measured rotation and blended with each new plane's by their variances (a
    scalar Kalman filter): a plane's variance grows with the 4th power of its centre's depth in step
    lengths, the carried normal's with the time since it was last measured.

    That normal is the road's where the fits are centred, some metres ahead, and where the road's grade changes
    (a vertical curve) it is not the normal of the road under the car: a plane through the centre along it
    extrapolates the road there to the car and misplaces it by up to ``curvature z^2 / 2``. So each blended normal
    is kept with the place along the drive where the road has its tilt (the plane's ``slope_depth`` ahead: its fit
    weighs the near road most, so metres beyond its centre), carried by the rotations since; once the car has driven
    there, that is the normal of the road under it. The angle between the two over that distance is the road's
    curvature, and the plane's distance is the centre's height along the normal under the car plus the curve's rise
    over the centre's points (``curvature depth_square / 2``): exact on a road of constant vertical curvature. A
    running mean of the curvature carries the normal ahead on as the car drives (carried by the rotation alone, a
    normal stays with the road where it was measured, behind the place the fits are centred at). Metres are the
    method's (its lengths in units of KITTI's camera height)."""

    def __init__(self, fit_sigma_rad: float = FIT_PITCH_SIGMA_RAD, drift_rad: float = GRADE_DRIFT_RAD) -> None:
        self.fit_sigma_rad = fit_sigma_rad
        self.drift_rad = drift_rad
        self.normal: np.ndarray | None = None  # unit, in the current frame
        self.variance = 0.0  # rad^2
        self.travelled_m = 0.0  # the car's place along the drive, from the step lengths :meth:`advance` was given
        self.curvature_per_m = 0.0  # how far the road's normal turns toward the forward axis per metre (a sag: > 0)
        self._ahead_normals = np.zeros((0, 3))  # blended normals of the road ahead (current frame, unit)
        self._ahead_places_m = np.zeros(0)  # and where along the drive the road had their tilt, ascending

    def advance(self, R_next_prev: np.ndarray, dt_s: float, step_m: float = 0.0) -> None:
        """Carry the normals into the next frame, ``dt_s`` seconds and about ``step_m`` metres later
        (``R_next_prev`` the step's rotation): the normal ahead turns with the road's curve as well."""
        if self.normal is not None:
            self.normal = turned_forward(R_next_prev @ self.normal, self.curvature_per_m * step_m)
            self.variance += self.drift_rad**2 * dt_s
        self.travelled_m += step_m
        kept = self._ahead_places_m > self.travelled_m - BEHIND_M
        self._ahead_normals = self._ahead_normals[kept] @ R_next_prev.T
        self._ahead_places_m = self._ahead_places_m[kept]

    def forget(self) -> None:
        """No rotation was measured: the next plane starts afresh."""
        self.normal = None
        self.curvature_per_m = 0.0
        self._ahead_normals, self._ahead_places_m = np.zeros((0, 3)), np.zeros(0)

    def smoothed(self, plane: RoadPlane, R_current_plane: np.ndarray, keep: bool = True,
                 camera_height_m: float | None = None) -> RoadPlane:
        """``plane`` (in the frame of its key frame, ``R_current_plane`` the rotation from it to the current
        frame) through its centre along the blended normal, or with ``camera_height_m`` (metres; the plane's distance
        then gives the metres of the key frame's span, which is one unit long) taken under the key frame's camera where
        the car has driven over a road measured ahead (class docstring; the returned normal bisects the two). ``keep``:
        the blend is carried on (current frame); False for a plane from road flow measured poorly (beyond DIS's reach
        without a prediction: the drive's first step, say; real clip 06 at 608 and 632 px, +28 and -20 %;
        :func:`flowvo.odometry.road_scale.road_flow_within_reach`), which only takes the carried normal."""
        variance = (self.fit_sigma_rad * (plane.centre[2] / FIT_REFERENCE_DEPTH) ** 2) ** 2
        normal, blended = plane.normal, variance
        if self.normal is not None:
            gain = self.variance / (self.variance + variance)
            normal = (1.0 - gain) * (R_current_plane.T @ self.normal) + gain * plane.normal
            normal /= np.linalg.norm(normal)
            blended = (1.0 - gain) * self.variance
        if keep:
            self.normal, self.variance = R_current_plane @ normal, blended
        ahead = RoadPlane(float(normal @ plane.centre), normal, plane.inlier_fraction, plane.centre)
        if camera_height_m is None or ahead.distance <= 0:
            return ahead
        metres_per_unit = camera_height_m / ahead.distance
        key_place_m = self.travelled_m - metres_per_unit
        slope_depth = plane.centre[2] if plane.slope_depth is None else plane.slope_depth
        depth_square = plane.centre[2] ** 2 if plane.depth_square is None else plane.depth_square
        slope_m = slope_depth * metres_per_unit  # how far ahead of the key frame the road has the blend's tilt
        under = self._normal_at(key_place_m)
        if keep:
            at = int(np.searchsorted(self._ahead_places_m, key_place_m + slope_m, side="right"))
            self._ahead_normals = np.insert(self._ahead_normals, at, R_current_plane @ normal, axis=0)
            self._ahead_places_m = np.insert(self._ahead_places_m, at, key_place_m + slope_m)
        if under is None:
            return ahead
        under = R_current_plane.T @ under
        turn = math.radians(mounting_of_road_normal(normal)[0] - mounting_of_road_normal(under)[0])  # the road's, from
        # under the camera to slope_depth ahead: how far the normal leans toward the forward axis, as a camera's pitch
        if keep:
            self.curvature_per_m += CURVE_WEIGHT * (turn / slope_m - self.curvature_per_m)
        chord = normal + under
        chord /= np.linalg.norm(chord)
        distance = float(under @ plane.centre) + turn * depth_square / (2.0 * slope_depth)  # the centre's height over
        # the road under the camera, and the curve's rise over the centre's points
        return RoadPlane(distance, chord, plane.inlier_fraction, plane.centre)

    def _normal_at(self, place_m: float) -> np.ndarray | None:
        """The normal of the road measured at ``place_m`` along the drive (current frame, unit; interpolated between
        the two places around it), or None where no kept place lies on each side of it."""
        places = self._ahead_places_m
        after = int(np.searchsorted(places, place_m))
        if after == 0 or after == len(places):
            return None
        low, high = places[after - 1], places[after]
        share = 0.0 if high == low else (place_m - low) / (high - low)
        normal = (1.0 - share) * self._ahead_normals[after - 1] + share * self._ahead_normals[after]
        return normal / np.linalg.norm(normal)


def turned_forward(normal: np.ndarray, angle_rad: float) -> np.ndarray:
    """``normal`` (unit) turned by ``angle_rad`` toward the camera's forward axis z, about the axis across both."""
    axis = np.cross(normal, np.array([0.0, 0.0, 1.0]))
    norm = np.linalg.norm(axis)
    if not angle_rad or norm < 1e-12:
        return normal
    axis /= norm
    return normal * np.cos(angle_rad) + np.cross(axis, normal) * np.sin(angle_rad)
