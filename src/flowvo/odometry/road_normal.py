"""The road's normal in the camera frame, blended over the trusted road planes and carried by the camera's rotation
(a scalar Kalman filter), the place along the drive where the road has the blend's tilt, and the road plane's
distance taken under the car (the road's normal there and its curve up to the plane's centre).

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

    That normal is the road's some metres ahead, and where the road's grade changes (a vertical curve) it is not the
    normal of the road under the car: a plane through the centre along it extrapolates the road there to the car and
    misplaces it by up to ``curvature z^2 / 2``. A fit has the road's tilt at its ``slope_depth`` ahead (it weighs the
    near road most, so metres beyond its centre); the blend, a weighted mean of the fits' normals, has it at the same
    weighted mean of their places (exact where the tilt changes evenly along the road). Each blended normal is kept
    with that place, carried by the rotations since; once the car has driven there, that is the normal of the road
    under it. The road's curvature is the angle between the blend and the normal kept at least a fit's slope distance
    behind its place (under the car, or behind it where the blend lags close to the car: both normals are smoothed,
    their slow errors shared out over a short stretch would swell), over the distance between them; the plane's
    distance is the centre's height along the normal under the car plus the curve's rise over the centre's points
    (``curvature depth_square / 2``): exact on a road of constant vertical curvature. Nothing is extrapolated: where
    no plane is measured (a stop, a slow stretch), the blend stays the road's where it was measured. Metres are the
    method's (its lengths in units of KITTI's camera height)."""

    def __init__(self, fit_sigma_rad: float = FIT_PITCH_SIGMA_RAD, drift_rad: float = GRADE_DRIFT_RAD) -> None:
        self.fit_sigma_rad = fit_sigma_rad
        self.drift_rad = drift_rad
        self.normal: np.ndarray | None = None  # unit, in the current frame
        self.variance = 0.0  # rad^2
        self.travelled_m = 0.0  # the car's place along the drive, from the step lengths :meth:`advance` was given
        self.place_m: float | None = None  # where along the drive the road has the blended normal's tilt
        self._ahead_normals = np.zeros((0, 3))  # blended normals of the road ahead (current frame, unit)
        self._ahead_places_m = np.zeros(0)  # and where along the drive the road had their tilt, ascending

    def advance(self, R_next_prev: np.ndarray, dt_s: float, step_m: float = 0.0) -> None:
        """Carry the normals into the next frame, ``dt_s`` seconds and about ``step_m`` metres later
        (``R_next_prev`` the step's rotation)."""
        if self.normal is not None:
            self.normal = R_next_prev @ self.normal
            self.variance += self.drift_rad**2 * dt_s
        self.travelled_m += step_m
        kept = self._ahead_places_m > self.travelled_m - BEHIND_M
        self._ahead_normals = self._ahead_normals[kept] @ R_next_prev.T
        self._ahead_places_m = self._ahead_places_m[kept]

    def forget(self) -> None:
        """No rotation was measured: the next plane starts afresh."""
        self.normal, self.place_m = None, None
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
        normal, blended, gain = plane.normal, variance, 1.0
        if self.normal is not None:
            gain = self.variance / (self.variance + variance)
            normal = (1.0 - gain) * (R_current_plane.T @ self.normal) + gain * plane.normal
            normal /= np.linalg.norm(normal)
            blended = (1.0 - gain) * self.variance
        ahead = RoadPlane(float(normal @ plane.centre), normal, plane.inlier_fraction, plane.centre)
        if camera_height_m is None or ahead.distance <= 0:
            if keep:
                self.normal, self.variance, self.place_m = R_current_plane @ normal, blended, None
            return ahead
        metres_per_unit = camera_height_m / ahead.distance
        key_place_m = self.travelled_m - metres_per_unit
        slope_depth = plane.centre[2] if plane.slope_depth is None else plane.slope_depth
        depth_square = plane.centre[2] ** 2 if plane.depth_square is None else plane.depth_square
        fit_place_m = key_place_m + slope_depth * metres_per_unit  # where the road has this fit's tilt
        place_m = fit_place_m if self.place_m is None else self.place_m + gain * (fit_place_m - self.place_m)
        under = self._normal_at(key_place_m)
        if keep:
            self.normal, self.variance, self.place_m = R_current_plane @ normal, blended, place_m
            at = int(np.searchsorted(self._ahead_places_m, place_m, side="right"))
            normals, places_m = self._ahead_normals, self._ahead_places_m  # inserted at ``at`` (np.insert: 57 us)
            self._ahead_normals = np.concatenate([normals[:at], self.normal[None], normals[at:]])
            self._ahead_places_m = np.concatenate([places_m[:at], [place_m], places_m[at:]])
        if under is None or place_m <= key_place_m:
            return ahead
        under = R_current_plane.T @ under
        behind_m = min(key_place_m, place_m - slope_depth * metres_per_unit)  # the curve's other end: under the car,
        # or a fit's slope distance behind the blend's place where that is farther (the first kept one at most)
        behind = self._normal_at(behind_m)
        if behind is None:
            behind_m, behind = self._ahead_places_m[0], self._ahead_normals[0]
        behind = R_current_plane.T @ behind
        turn = math.radians(mounting_of_road_normal(normal)[0] - mounting_of_road_normal(behind)[0])  # the road's, over
        # that stretch: how far the normal leans toward the forward axis, as a camera's pitch
        curve = turn / ((place_m - behind_m) / metres_per_unit)  # radians per unit of the span
        chord = normal + under
        chord /= np.linalg.norm(chord)
        distance = float(under @ plane.centre) + curve * depth_square / 2.0  # the centre's height over the road under
        # the camera, and the curve's rise over the centre's points
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

