"""The road's normal in the camera frame, blended over the trusted road planes and carried by the camera's rotation
(a scalar Kalman filter). Angles in radians; planes in the camera frame, distances in units of the step.
"""

from __future__ import annotations

import numpy as np

from flowvo.odometry.road_plane import RoadPlane

FIT_PITCH_SIGMA_RAD = 0.005  # a plane's normal from one step of road, its centre 7.4 step lengths ahead (real
# clip 06 at 1.2 m a step: fitted pitch scatters by 0.25 deg, real pitching included); it grows with the square
# of the depth's ratio to the baseline, as the heights it is fitted to do
FIT_REFERENCE_DEPTH = 7.4  # step lengths
GRADE_DRIFT_RAD = 0.0035  # per square-root second: how fast the road's normal may change beyond the camera's
# rotation (grade, pitching); with FIT_PITCH_SIGMA_RAD it gives a new plane at 7.4 step lengths weight 0.2 at 10 Hz


class RoadNormal:
    """The road's normal in the camera frame, smoothed over the trusted road planes.

    One step's fit tilts its plane about the centre of its near road points: a pitch error of 1 degree moves
    the plane's distance under the camera by 3.5-7.5 % (real clips), and its fitted pitch scatters by
    0.3-0.7 degrees. The road's normal in the camera frame changes only as the camera turns, which the
    tracked points measure far better, and as the road's grade changes, slowly. So the normal is carried
    from frame to frame by the measured rotation and blended with each new plane's by their variances (a
    scalar Kalman filter): a plane's variance grows with the 4th power of its centre's depth in step
    lengths, the carried normal's with the time since it was last measured. The plane's distance is then
    taken through its own centre along the blended normal.
    """

    def __init__(self, fit_sigma_rad: float = FIT_PITCH_SIGMA_RAD, drift_rad: float = GRADE_DRIFT_RAD) -> None:
        self.fit_sigma_rad = fit_sigma_rad
        self.drift_rad = drift_rad
        self.normal: np.ndarray | None = None  # unit, in the current frame
        self.variance = 0.0  # rad^2

    def advance(self, R_next_prev: np.ndarray, dt_s: float) -> None:
        """Carry the normal into the next frame, ``dt_s`` seconds later (``R_next_prev`` the step's rotation)."""
        if self.normal is not None:
            self.normal = R_next_prev @ self.normal
            self.variance += self.drift_rad**2 * dt_s

    def forget(self) -> None:
        """No rotation was measured: the next plane starts afresh."""
        self.normal = None

    def smoothed(self, plane: RoadPlane, R_current_plane: np.ndarray, keep: bool = True) -> RoadPlane:
        """``plane`` (in the frame of its key frame, ``R_current_plane`` the rotation from it to the current
        frame) through its centre along the blended normal. ``keep``: the blend is carried on (current frame);
        False for a plane from road flow measured poorly (beyond DIS's reach without a prediction: the
        drive's first step, say; real clip 06 at 608 and 632 px, +28 and -20 %;
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
        return RoadPlane(float(normal @ plane.centre), normal, plane.inlier_fraction, plane.centre)
