"""Metric scale from the road: the road crop and grid, the road points triangulated and the trusted plane through
them (:mod:`flowvo.odometry.road_plane`), the road homographies that predict the road's flow, and the policy of when
the network's distance stands in for a missing road.

Pure functions over NumPy arrays. Frames: camera frame x right, y down, z forward; pixels of the frame the
flow was computed at; lengths in metres, or in units of the step where said so.
"""

from __future__ import annotations

import numpy as np

from flowvo.camera import mounting_rotation
from flowvo.odometry.numeric import percentile
from flowvo.odometry.road_plane import (
    MAX_ROAD_TILT_RAD,
    MIN_ROAD_INLIER_FRACTION,
    MIN_ROAD_POINTS,
    RoadPlane,
    fit_road_plane,
    in_camera_frame,
    is_trusted_road,
)
from flowvo.odometry.road_profile import RoadProfile
from flowvo.odometry.road_tally import RoadPlaneTally
from flowvo.odometry.two_view import EssentialMotion, inverse_intrinsics, translation_parallax_px, triangulate

ROAD_ROWS = (0.10, 0.45)  # the road grid's rows below the principal point, in frame heights (KITTI: 7-32 m ahead)
ROAD_HALF_WIDTH = 0.2  # the road grid's half width around the principal point, in frame widths
ROAD_CROP_HALF_WIDTH = 0.25  # the road crop's (:func:`road_crop`), wider than the grid: road points move outwards
ROAD_ROWS_NEEDED = 0.35  # frame heights below the principal point the grid must find inside the frame; the
# nearer rows are read where the frame holds them
GRID_MARGIN_PX = 4  # flow at the outermost pixels is unreliable
HORIZON_MARGIN = 0.05  # frame heights: how far below the horizon of a camera pitched up or rolled the road grid's top
# row must lie (as far as the road crop's top lies above a level camera's grid); the grid starts where a level camera's
# does unless that is nearer the horizon. Kept 0.10 below the horizon (as a level camera's is below its own), the real
# dash-cam told its pitch (1.8 degrees up) lost its grid's farthest rows above its bonnet: 35.1 m/s against 32.7 run
# level, its second half 42.4 against 33.0, its planes then asking for 3 degrees more; now 32.7 and 32.9. The
# synthetic camera pitched 5 degrees up, told, read 1.16 -> 1.27 % (620 px), 0.96 -> 1.01 % (full size): real frames
# decided (docs/results.md#the-road-grid-of-a-camera-pitched-up)


def road_room(image_hw: tuple[int, int], K: np.ndarray) -> str | None:
    """Why the road grid does not fit in a frame of ``image_hw`` (pixels) with intrinsics ``K``, or None
    when it does: its rows from ``cy + ROAD_ROWS[0] * H`` to at least ``cy + ROAD_ROWS_NEEDED * H`` and its
    columns ``cx +- ROAD_HALF_WIDTH * W`` must lie inside the frame (a principal point near the border
    leaves no road to measure)."""
    h, w = image_hw
    cx, cy = float(K[0, 2]), float(K[1, 2])
    max_cy = h - GRID_MARGIN_PX - ROAD_ROWS_NEEDED * h
    cx_range = (ROAD_HALF_WIDTH * w + GRID_MARGIN_PX, w - GRID_MARGIN_PX - ROAD_HALF_WIDTH * w)
    if cy <= max_cy and cx_range[0] <= cx <= cx_range[1]:
        return None
    return (f"principal point ({cx:g}, {cy:g}) leaves no room for the road crop on {w}x{h} frames: it needs cx in "
            f"[{cx_range[0]:.0f}, {cx_range[1]:.0f}] and cy <= {max_cy:.0f} px")


def horizon_below_px(K: np.ndarray, pitch_deg: float, roll_deg: float = 0.0, half_width_px: float = 0.0) -> float:
    """How far below the principal point (pixels, ideal pinhole) the horizon's lowest point within ``half_width_px``
    columns of it lies for a camera pitched ``pitch_deg`` (down positive) and rolled ``roll_deg`` (degrees,
    :func:`flowvo.camera.mounting_rotation`): 0 where it is at or above it (a level camera, one pitched down).

    The horizon is where viewing rays run parallel to the road: ``n . (x, y, 1) = 0`` for the road's normal ``n`` in
    the camera frame (normalised coordinates); a rolled camera's horizon slopes, and it is lowest at one side."""
    normal = mounting_rotation(pitch_deg, roll_deg).T @ np.array([0.0, 1.0, 0.0])
    lowest = (abs(normal[0]) * half_width_px / float(K[0, 0]) - normal[2]) / normal[1]
    return max(0.0, float(K[1, 1]) * lowest)


def road_top_shift_px(horizon_px: float, image_h: int, margin: float = HORIZON_MARGIN) -> float:
    """How far (pixels) the road grid and crop start below a level camera's for a camera whose horizon lies
    ``horizon_px`` below the principal point (:func:`horizon_below_px`) in frames ``image_h`` high: enough that the
    grid's top row (``ROAD_ROWS[0]`` frame heights below the principal point) stays ``margin`` frame heights below the
    horizon; 0 where it is already."""
    return max(0.0, horizon_px - (ROAD_ROWS[0] - margin) * image_h)


def road_grid(image_hw: tuple[int, int], K: np.ndarray, rows: tuple[float, float] = ROAD_ROWS,
              half_width: float = ROAD_HALF_WIDTH, step_px: int = GRID_MARGIN_PX, top_shift_px: float = 0.0
              ) -> np.ndarray:
    """Where to read the road's flow: a regular grid (R, 2) float32 of rows ``cy + rows * H`` within
    ``half_width * W`` of the principal point column, where the road ahead usually is; its top rows start
    ``top_shift_px`` lower (:func:`road_top_shift_px`: a camera pitched up sees sky and distant scenery where a
    level one sees road; synthetic camera pitched 5 degrees up, told so: t_err 6.81 -> 4.65 %). The nearest rows
    measure the road best (a road point's parallax falls with the square of its distance); their large,
    stretching motion is within reach because the default method predicts the road's flow."""
    h, w = image_hw
    cx, cy = K[0, 2], K[1, 2]
    top, bottom = int(cy + top_shift_px + rows[0] * h), min(h - GRID_MARGIN_PX, int(cy + rows[1] * h))
    left, right = max(GRID_MARGIN_PX, int(cx - half_width * w)), min(w - GRID_MARGIN_PX, int(cx + half_width * w))
    ys, xs = np.mgrid[top:bottom:step_px, left:right:step_px]
    return np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float32)


def road_crop(image_hw: tuple[int, int], K: np.ndarray, rows: tuple[float, float] = (0.05, 0.50),
              half_width: float = ROAD_CROP_HALF_WIDTH, top_shift_px: float = 0.0) -> tuple[slice, slice]:
    """The part of the frame whose dense flow the road scale needs: the :func:`road_grid` band with margins
    (road points move down and outwards between frames). Rows ``cy + rows * H`` (the top ones
    ``top_shift_px`` lower), columns within ``half_width * W`` of the principal point."""
    h, w = image_hw
    cx, cy = K[0, 2], K[1, 2]
    return (slice(int(cy + top_shift_px + rows[0] * h), min(h, int(cy + rows[1] * h))),
            slice(max(0, int(cx - half_width * w)), min(w, int(cx + half_width * w))))


def road_points_in_view(points_prev: np.ndarray, points_next: np.ndarray, image_hw: tuple[int, int],
                        margin_px: int = GRID_MARGIN_PX) -> tuple[np.ndarray, np.ndarray]:
    """The road correspondences (N, 2) whose second position lies inside a frame of ``image_hw`` (pixels),
    ``margin_px`` from its edges: the nearest road leaves the frame on a long step, and the flow there is
    the frame's replicated border, not the road."""
    h, w = image_hw
    x, y = points_next[:, 0], points_next[:, 1]
    inside = (x >= margin_px) & (x < w - margin_px) & (y >= margin_px) & (y < h - margin_px)
    return points_prev[inside], points_next[inside]


def road_points(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray, motion: EssentialMotion,
                min_parallax_px: float = 0.0, levelling: np.ndarray | None = None) -> np.ndarray | None:
    """The road correspondences triangulated (N, 3; units of the step) in the level frame (``levelling``: for a
    camera not mounted level, the rotation from its frame to a level camera's,
    :attr:`flowvo.camera.Camera.road_levelling`; None: the camera's own frame). None for fewer than
    ``MIN_ROAD_POINTS``, and when nine in ten road points moved less than ``min_parallax_px`` (pixels) beyond what
    the rotation explains: a road whose flow is lost (no texture, a car right in front moving along) has no depth to
    triangulate (the nearest rows move most, hence the 90th percentile: at walking pace the far rows barely move)."""
    if len(points_prev) < MIN_ROAD_POINTS:  # every road point left the frame, say
        return None
    if min_parallax_px and near_road_parallax_px(points_prev, points_next, K, motion.R) < min_parallax_px:
        return None
    points = triangulate(points_prev, points_next, K, motion)
    return points if levelling is None else points @ levelling.T


def trusted_road_plane(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray, motion: EssentialMotion,
                       max_tilt_rad: float = MAX_ROAD_TILT_RAD, min_inlier_fraction: float = MIN_ROAD_INLIER_FRACTION,
                       min_parallax_px: float = 0.0, levelling: np.ndarray | None = None,
                       tally: RoadPlaneTally | None = None) -> RoadPlane | None:
    """The road plane the camera stands on, from road correspondences (distance in units of the step, the
    camera's frame), or None: the plane fitted to the :func:`road_points` that passes
    :func:`flowvo.odometry.road_plane.is_trusted_road`; each candidate is counted in ``tally`` when given."""
    points = road_points(points_prev, points_next, K, motion, min_parallax_px, levelling)
    plane = None if points is None else trusted_plane_among(points, max_tilt_rad, min_inlier_fraction, tally)
    return None if plane is None else in_camera_frame(plane, levelling)


def trusted_plane_among(points: np.ndarray, max_tilt_rad: float = MAX_ROAD_TILT_RAD,
                        min_inlier_fraction: float = MIN_ROAD_INLIER_FRACTION, tally: RoadPlaneTally | None = None,
                        profile: RoadProfile | None = None) -> RoadPlane | None:
    """The plane fitted to triangulated road ``points`` (N, 3; units of the step) that passes
    :func:`flowvo.odometry.road_plane.is_trusted_road`, in the points' frame, or None (``tally`` as in
    :func:`trusted_road_plane`; with a ``profile``, the points it keeps are fitted: the caller lets it learn from the
    trusted plane, :class:`flowvo.odometry.road_profile.RoadProfile`)."""
    plane = fit_road_plane(points if profile is None else points[profile.keep(points)])
    if plane is None:
        return None
    trusted = is_trusted_road(plane, max_tilt_rad, min_inlier_fraction)
    if tally is not None:
        tally.add(plane, trusted, max_tilt_rad)
    return plane if trusted else None


NEAR_ROAD_PERCENTILE = 90  # the near road moves most: its flow decides whether one step's road was within reach


def road_flow_within_reach(road_motion_px: np.ndarray, reach_px: float, predicted: bool, steps: int = 1) -> bool:
    """Whether a road flow was measured well enough to carry its plane's normal on: it started from a
    prediction, or the road moved less than ``reach_px``, the motion DIS follows without one
    (``road_motion_px``: the road points' motions, pixels). For one step's flow the near road decides
    (``NEAR_ROAD_PERCENTILE``): beyond reach DIS measures it short and the plane comes out tilted while the
    median point can stay within reach (real clip 06's first step at 632 px: median 8.3, 90th percentile
    15.3 px at the reference width, the road 20 % short, its pitch 1.9 degrees off). For a flow from a road
    key frame ``steps`` back the median point decides: such spans, near road at 12-16 px, measured the road
    within 2-3 % on a synthetic 30 frames/s camera, and leaving them out of the normal cost it 2.2x."""
    if predicted:
        return True
    if not len(road_motion_px):
        return False
    q = NEAR_ROAD_PERCENTILE if steps == 1 else 50
    return percentile(road_motion_px, q) < reach_px


def road_step_length_m(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray, motion: EssentialMotion,
                       camera_height_m: float) -> float | None:
    """Metric length of the step: the camera height over the trusted road plane's distance in step units
    (see :func:`trusted_road_plane`); None without a trusted plane."""
    plane = trusted_road_plane(points_prev, points_next, K, motion)
    return None if plane is None else camera_height_m / plane.distance


def road_homography(K: np.ndarray, motion: EssentialMotion, plane: RoadPlane) -> np.ndarray:
    """The 3x3 homography that maps pixels of road points in the first frame to the second (ideal pinhole
    pixels): ``K (R + t n^T / d) K^-1``, with the plane ``n . X = d`` in the first camera's frame and the
    motion's unit translation (the plane's distance is in the same units)."""
    return K @ (motion.R + np.outer(motion.t_dir, plane.normal) / plane.distance) @ inverse_intrinsics(K)


def onward_road_homography(K: np.ndarray, plane: RoadPlane, key_motion: EssentialMotion, key_length_m: float,
                           step_motion: EssentialMotion, step_length_m: float, height_m: float) -> np.ndarray:
    """The road homography from a road key frame to the frame after the current one (ideal pinhole pixels), at
    constant velocity: the motion from the key frame to the current frame (``key_motion``, ``key_length_m``
    metres), then the current step (``step_motion``, ``step_length_m``) once more. ``plane`` is the key frame's
    road (its normal; the road lies ``height_m`` metres below the key frame's camera)."""
    R = step_motion.R @ key_motion.R
    t_m = step_motion.R @ key_motion.t_dir * key_length_m + step_motion.t_dir * step_length_m
    return K @ (R + np.outer(t_m, plane.normal) / height_m) @ inverse_intrinsics(K)


def metric_road_homography(K: np.ndarray, T_next_key: np.ndarray, normal: np.ndarray, height_m: float) -> np.ndarray:
    """The road homography from a key frame to a later frame (ideal pinhole pixels) under the metric motion
    ``T_next_key`` (4x4, the key frame's points into the later frame's), the road ``height_m`` metres below the key
    frame's camera along ``normal`` (unit, the key frame's camera frame)."""
    return K @ (T_next_key[:3, :3] + np.outer(T_next_key[:3, 3], normal) / height_m) @ inverse_intrinsics(K)


def near_road_parallax_px(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray, R: np.ndarray) -> float:
    """How far the near road moved beyond the rotation ``R`` (``R_next_prev``), pixels: :func:`near_of` the road
    correspondences' (N, 2) translation parallax."""
    if not len(points_prev):
        return 0.0
    return near_of(translation_parallax_px(points_prev, points_next, K, R))


def near_of(parallax_px: np.ndarray) -> float:
    """The near road's parallax (pixels): the ``NEAR_ROAD_PERCENTILE`` of road points' parallax (N,; 0 without any)."""
    return percentile(parallax_px, NEAR_ROAD_PERCENTILE) if len(parallax_px) else 0.0


NETWORK_AFTER_S = 1.0  # the speed prior bridges shorter gaps in the road measurements on its own


class NetworkFallbackPolicy:
    """When the network's distance stands in for the road: once no trusted road plane has been seen for
    more than ``after_s`` seconds (a slope ahead, a car right in front, a hill side). Measured on the real
    clips: after 1 s keeps clip 01's path within 3 %; at once, clip 07 ran 3 % long (the network's bias)."""

    def __init__(self, after_s: float = NETWORK_AFTER_S) -> None:
        self.after_s = after_s
        self.last_road_time_s = -np.inf
        self.network_steps = 0

    def road_seen(self, time_s: float) -> None:
        """The road was seen at ``time_s`` (seconds): a trusted road plane gave the step, or the planes await the
        drive's mounting."""
        self.last_road_time_s = time_s

    def network_needed(self, time_s: float) -> bool:
        """True when the step at ``time_s`` should take the network's distance (and counts it)."""
        needed = time_s - self.last_road_time_s > self.after_s
        self.network_steps += needed
        return needed
