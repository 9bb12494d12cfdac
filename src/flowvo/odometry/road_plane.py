"""The road plane: a robust plane through triangulated road points, the gates that trust it as the road the camera
stands on (tilt, inliers), and its way from the road-levelled frame into the camera's.

Pure functions over NumPy arrays. Frames: camera frame x right, y down, z forward (or the road-levelled camera frame
where said so); distances in units of the step.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from flowvo.geometry import cross
from flowvo.odometry.numeric import median, row_norms

MIN_ROAD_POINTS = 20  # a plane through fewer road points is not trusted


@dataclass(frozen=True)
class RoadPlane:
    """A plane ``normal . X = distance`` (camera frame, unit normal with n_y > 0) fitted to road points,
    the fraction of the points within the inlier tolerance, and ``centre``, the point of the plane its fit
    pivots about (the inliers' weighted centroid). From a fit, the weighted moments of its inliers' depth:
    ``slope_depth``, the depth at which a road curving in depth has the plane's tilt (``z + m3 / (2 m2)``, the
    centroid's depth plus the third central moment over twice the second: the weights favour the near road, so it
    lies metres beyond the centroid), and ``depth_square``, the mean square depth (``z^2 + m2``): on a road
    ``y = h - curvature z^2 / 2`` the centroid lies ``curvature depth_square / 2`` off the road under the camera.
    Same unit as the points; None where the plane was not fitted."""

    distance: float
    normal: np.ndarray
    inlier_fraction: float
    centre: np.ndarray
    slope_depth: float | None = None
    depth_square: float | None = None

    @classmethod
    def level(cls, distance: float) -> RoadPlane:
        """The road straight below the camera's down axis at ``distance``, every point an inlier."""
        return cls(distance, np.array([0.0, 1.0, 0.0]), 1.0, np.array([0.0, distance, 0.0]))

    @property
    def tilt_rad(self) -> float:
        """Angle between the plane's normal and the camera's down axis (pitch and roll of the road)."""
        return float(np.arccos(min(max(self.normal[1], -1.0), 1.0)))


@functools.lru_cache(maxsize=512)
def _triple_rows(count: int, iterations: int, seed: int) -> np.ndarray:
    """The RANSAC's point triples (iterations, 3) among ``count`` points, drawn with ``seed``: the same draw for the
    same count (a generator made for each fit cost 90 us of the stream's frame)."""
    rows = np.random.default_rng(seed).integers(0, count, size=(iterations, 3))
    rows.flags.writeable = False
    return rows


def fit_road_plane(points: np.ndarray, iterations: int = 64, min_normal_y: float = 0.95,
                   inlier_fraction_of_height: float = 0.03, seed: int = 0) -> RoadPlane | None:
    """Robust plane through road points (N, 3) below the camera (y down), or None.

    RANSAC over point triples whose normal is within ``acos(min_normal_y)`` of the camera's down axis,
    inliers within a fraction of the median height, then a least-squares refit that weighs each inlier by
    the inverse variance of its height: triangulated from a step, a road point's height errs in proportion
    to the square of its depth ``z`` (its parallax falls with ``z^2``), so the weights are ``z^-4`` and the
    near road carries the plane.
    """
    total = len(points)
    points = points[(points[:, 2] > 0) & (points[:, 1] > 0)]
    if len(points) < MIN_ROAD_POINTS:
        return None
    triples = points[_triple_rows(len(points), iterations, seed)]
    normals = cross(triples[:, 1] - triples[:, 0], triples[:, 2] - triples[:, 0])
    norms = row_norms(normals)
    usable = norms > 1e-12
    normals = normals[usable] / norms[usable, None]
    normals *= np.sign(normals[:, 1:2] + 1e-12)
    triples = triples[usable]
    upright = normals[:, 1] >= min_normal_y
    if not upright.any():
        return None
    normals, triples = normals[upright], triples[upright]
    offsets = np.einsum("ij,ij->i", normals, triples[:, 0])
    tolerance = inlier_fraction_of_height * median(points[:, 1])
    distances = points @ normals.T  # (N, hypotheses), in place from here: 0.23 -> 0.1 ms a frame
    distances -= offsets
    np.abs(distances, out=distances)
    best = int(np.count_nonzero(distances < tolerance, axis=0).argmax())
    inliers = points[distances[:, best] < tolerance]
    if len(inliers) < 10:
        return None
    weights = inliers[:, 2] ** -4.0
    weights /= weights.sum()
    centre = weights @ inliers
    normal = np.linalg.svd((inliers - centre) * np.sqrt(weights)[:, None], full_matrices=False)[2][2]
    normal = normal if normal[1] > 0 else -normal
    offsets = inliers[:, 2] - centre[2]
    spread, skew = float(weights @ offsets**2), float(weights @ offsets**3)
    slope_depth = centre[2] + (skew / (2.0 * spread) if spread > 1e-12 * centre[2] ** 2 else 0.0)
    return RoadPlane(float(normal @ centre), normal, len(inliers) / total, centre, float(slope_depth),
                     float(centre[2] ** 2 + spread))


MAX_ROAD_TILT_RAD = np.radians(4.0)
MIN_ROAD_INLIER_FRACTION = 0.05
MIN_ROAD_DEPRESSION_RAD = np.radians(1.0)  # the plane's weighted centre lies at least this far below the camera's
# view of the plane's horizon: a plane through the camera is no road (the rays of one image row are: their points
# lie on it at any depth, and from a camera pitched up, run as if level, such planes passed the tilt gate once the
# drive had taken a wrong pitch, at 1e-15 step lengths below the camera; a real road's near rows lie 5-15 degrees down)


def is_trusted_road(plane: RoadPlane, max_tilt_rad: float = MAX_ROAD_TILT_RAD,
                    min_inlier_fraction: float = MIN_ROAD_INLIER_FRACTION) -> bool:
    """Whether a candidate plane (level frame) is the road the camera stands on: below the camera
    (:func:`is_below_camera`), tilted at
    most ``max_tilt_rad`` from the road's normal (else a slope ahead, a hill side) and fitting at least
    ``min_inlier_fraction`` of the points. Measured on the real clips, step lengths off by more than 15 %
    came with a median tilt of 3-8 degrees and 8 % inliers; good ones 1.4 degrees, 30 %."""
    return is_below_camera(plane) and plane.tilt_rad <= max_tilt_rad and plane.inlier_fraction >= min_inlier_fraction


def is_below_camera(plane: RoadPlane) -> bool:
    """Whether the camera looks down on a candidate plane: its weighted centre ``MIN_ROAD_DEPRESSION_RAD`` or more
    below the plane's horizon (a plane through the camera or above it is no road, whatever its tilt)."""
    return plane.distance > np.tan(MIN_ROAD_DEPRESSION_RAD) * plane.centre[2]


def in_camera_frame(plane: RoadPlane, levelling: np.ndarray | None) -> RoadPlane:
    """A plane of the level frame in the camera's frame (``levelling`` as in
    :func:`flowvo.odometry.road_scale.road_points`)."""
    if levelling is None:
        return plane
    return RoadPlane(plane.distance, levelling.T @ plane.normal, plane.inlier_fraction, levelling.T @ plane.centre,
                     plane.slope_depth, plane.depth_square)
