"""Metric scale from the road: the road crop and grid, the road plane fitted to triangulated road points,
its gates (tilt, inliers), and the policy of when the network's distance stands in for a missing road.

Pure functions over NumPy arrays. Frames: camera frame x right, y down, z forward; pixels of the frame the
flow was computed at; lengths in metres, or in units of the step where said so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from flowvo.camera import mounting_rotation
from flowvo.odometry.two_view import EssentialMotion, translation_parallax_px, triangulate

if TYPE_CHECKING:
    from flowvo.odometry.road_profile import RoadProfile

ROAD_ROWS = (0.10, 0.45)  # the road grid's rows below the principal point, in frame heights (KITTI: 7-32 m ahead)
ROAD_HALF_WIDTH = 0.2  # the road grid's half width around the principal point, in frame widths
ROAD_CROP_HALF_WIDTH = 0.25  # the road crop's (:func:`road_crop`), wider than the grid: road points move outwards
ROAD_ROWS_NEEDED = 0.35  # frame heights below the principal point the grid must find inside the frame; the
# nearer rows are read where the frame holds them
GRID_MARGIN_PX = 4  # flow at the outermost pixels is unreliable
MIN_ROAD_POINTS = 20  # a plane through fewer road points is not trusted


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


def road_grid(image_hw: tuple[int, int], K: np.ndarray, rows: tuple[float, float] = ROAD_ROWS,
              half_width: float = ROAD_HALF_WIDTH, step_px: int = GRID_MARGIN_PX, horizon_below_px: float = 0.0
              ) -> np.ndarray:
    """Where to read the road's flow: a regular grid (R, 2) float32 of rows ``cy + rows * H`` within
    ``half_width * W`` of the principal point column, where the road ahead usually is; its top rows start
    ``horizon_below_px`` lower (:func:`horizon_below_px`: a camera pitched up sees sky and distant scenery where a
    level one sees road; synthetic camera pitched 5 degrees up, told so: t_err 6.81 -> 4.65 %). The nearest rows
    measure the road best (a road point's parallax falls with the square of its distance); their large,
    stretching motion is within reach because the default method predicts the road's flow."""
    h, w = image_hw
    cx, cy = K[0, 2], K[1, 2]
    top, bottom = int(cy + horizon_below_px + rows[0] * h), min(h - GRID_MARGIN_PX, int(cy + rows[1] * h))
    left, right = max(GRID_MARGIN_PX, int(cx - half_width * w)), min(w - GRID_MARGIN_PX, int(cx + half_width * w))
    ys, xs = np.mgrid[top:bottom:step_px, left:right:step_px]
    return np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float32)


def road_crop(image_hw: tuple[int, int], K: np.ndarray, rows: tuple[float, float] = (0.05, 0.50),
              half_width: float = ROAD_CROP_HALF_WIDTH, horizon_below_px: float = 0.0) -> tuple[slice, slice]:
    """The part of the frame whose dense flow the road scale needs: the :func:`road_grid` band with margins
    (road points move down and outwards between frames). Rows ``cy + rows * H`` (the top ones
    ``horizon_below_px`` lower), columns within ``half_width * W`` of the principal point."""
    h, w = image_hw
    cx, cy = K[0, 2], K[1, 2]
    return (slice(int(cy + horizon_below_px + rows[0] * h), min(h, int(cy + rows[1] * h))),
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


@dataclass(frozen=True)
class RoadPlane:
    """A plane ``normal . X = distance`` (camera frame, unit normal with n_y > 0) fitted to road points,
    the fraction of the points within the inlier tolerance, and ``centre``, the point of the plane its fit
    pivots about (the inliers' weighted centroid)."""

    distance: float
    normal: np.ndarray
    inlier_fraction: float
    centre: np.ndarray

    @classmethod
    def level(cls, distance: float) -> RoadPlane:
        """The road straight below the camera's down axis at ``distance``, every point an inlier."""
        return cls(distance, np.array([0.0, 1.0, 0.0]), 1.0, np.array([0.0, distance, 0.0]))

    @property
    def tilt_rad(self) -> float:
        """Angle between the plane's normal and the camera's down axis (pitch and roll of the road)."""
        return float(np.arccos(np.clip(self.normal[1], -1.0, 1.0)))


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
    rng = np.random.default_rng(seed)
    triples = points[rng.integers(0, len(points), size=(iterations, 3))]
    normals = np.cross(triples[:, 1] - triples[:, 0], triples[:, 2] - triples[:, 0])
    norms = np.linalg.norm(normals, axis=1)
    usable = norms > 1e-12
    normals = normals[usable] / norms[usable, None]
    normals *= np.sign(normals[:, 1:2] + 1e-12)
    triples = triples[usable]
    upright = normals[:, 1] >= min_normal_y
    if not upright.any():
        return None
    normals, triples = normals[upright], triples[upright]
    offsets = np.einsum("ij,ij->i", normals, triples[:, 0])
    tolerance = inlier_fraction_of_height * float(np.median(points[:, 1]))
    distances = np.abs(points @ normals.T - offsets)  # (N, hypotheses)
    counts = (distances < tolerance).sum(axis=0)
    best = int(counts.argmax())
    inliers = points[distances[:, best] < tolerance]
    if len(inliers) < 10:
        return None
    weights = inliers[:, 2] ** -4.0
    weights /= weights.sum()
    centre = weights @ inliers
    normal = np.linalg.svd((inliers - centre) * np.sqrt(weights)[:, None], full_matrices=False)[2][2]
    normal = normal if normal[1] > 0 else -normal
    return RoadPlane(float(normal @ centre), normal, len(inliers) / total, centre)


MAX_ROAD_TILT_RAD = np.radians(4.0)
MIN_ROAD_INLIER_FRACTION = 0.05


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


def is_trusted_road(plane: RoadPlane, max_tilt_rad: float = MAX_ROAD_TILT_RAD,
                    min_inlier_fraction: float = MIN_ROAD_INLIER_FRACTION) -> bool:
    """Whether a candidate plane (level frame) is the road the camera stands on: below the camera, tilted at
    most ``max_tilt_rad`` from the road's normal (else a slope ahead, a hill side) and fitting at least
    ``min_inlier_fraction`` of the points. Measured on the real clips, step lengths off by more than 15 %
    came with a median tilt of 3-8 degrees and 8 % inliers; good ones 1.4 degrees, 30 %."""
    return plane.distance > 0 and plane.tilt_rad <= max_tilt_rad and plane.inlier_fraction >= min_inlier_fraction


def in_camera_frame(plane: RoadPlane, levelling: np.ndarray | None) -> RoadPlane:
    """A plane of the level frame in the camera's frame (``levelling`` as in :func:`road_points`)."""
    if levelling is None:
        return plane
    return RoadPlane(plane.distance, levelling.T @ plane.normal, plane.inlier_fraction, levelling.T @ plane.centre)


def trusted_road_plane(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray, motion: EssentialMotion,
                       max_tilt_rad: float = MAX_ROAD_TILT_RAD, min_inlier_fraction: float = MIN_ROAD_INLIER_FRACTION,
                       min_parallax_px: float = 0.0, levelling: np.ndarray | None = None,
                       tally: RoadPlaneTally | None = None, profile: RoadProfile | None = None) -> RoadPlane | None:
    """The road plane the camera stands on, from road correspondences (distance in units of the step, the
    camera's frame), or None: the plane fitted to the :func:`road_points` that passes :func:`is_trusted_road`; each
    candidate is counted in ``tally`` when given. With a ``profile``, the points it keeps are fitted, and it learns
    from every trusted plane (:class:`flowvo.odometry.road_profile.RoadProfile`)."""
    points = road_points(points_prev, points_next, K, motion, min_parallax_px, levelling)
    if points is None:
        return None
    plane = fit_road_plane(points if profile is None else points[profile.keep(points)])
    if plane is None:
        return None
    trusted = is_trusted_road(plane, max_tilt_rad, min_inlier_fraction)
    if tally is not None:
        tally.add(plane, trusted, max_tilt_rad)
    if trusted and profile is not None:
        profile.observe(points, plane)
    return in_camera_frame(plane, levelling) if trusted else None


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
    percentile = NEAR_ROAD_PERCENTILE if steps == 1 else 50
    return float(np.percentile(road_motion_px, percentile)) < reach_px


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
        drive's first step, say; real clip 06 at 608 and 632 px, +28 and -20 %; :func:`road_flow_within_reach`),
        which only takes the carried normal."""
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
    return K @ (motion.R + np.outer(motion.t_dir, plane.normal) / plane.distance) @ np.linalg.inv(K)


def onward_road_homography(K: np.ndarray, plane: RoadPlane, key_motion: EssentialMotion, key_length_m: float,
                           step_motion: EssentialMotion, step_length_m: float, height_m: float) -> np.ndarray:
    """The road homography from a road key frame to the frame after the current one (ideal pinhole pixels), at
    constant velocity: the motion from the key frame to the current frame (``key_motion``, ``key_length_m``
    metres), then the current step (``step_motion``, ``step_length_m``) once more. ``plane`` is the key frame's
    road (its normal; the road lies ``height_m`` metres below the key frame's camera)."""
    R = step_motion.R @ key_motion.R
    t_m = step_motion.R @ key_motion.t_dir * key_length_m + step_motion.t_dir * step_length_m
    return K @ (R + np.outer(t_m, plane.normal) / height_m) @ np.linalg.inv(K)


def metric_road_homography(K: np.ndarray, T_next_key: np.ndarray, normal: np.ndarray, height_m: float) -> np.ndarray:
    """The road homography from a key frame to a later frame (ideal pinhole pixels) under the metric motion
    ``T_next_key`` (4x4, the key frame's points into the later frame's), the road ``height_m`` metres below the key
    frame's camera along ``normal`` (unit, the key frame's camera frame)."""
    return K @ (T_next_key[:3, :3] + np.outer(T_next_key[:3, 3], normal) / height_m) @ np.linalg.inv(K)


def near_road_parallax_px(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray, R: np.ndarray) -> float:
    """How far the near road moved beyond the rotation ``R`` (``R_next_prev``), pixels: the ``NEAR_ROAD_PERCENTILE``
    of the road correspondences' (N, 2) translation parallax (0 without any)."""
    if not len(points_prev):
        return 0.0
    return float(np.percentile(translation_parallax_px(points_prev, points_next, K, R), NEAR_ROAD_PERCENTILE))


MIN_TILTED_FOR_HINT = 20  # candidate planes refused as tilted before they say anything of the mounting
MIN_HINT_DEG = 1.0  # the candidates' median pitch (or roll) must be this far from the one given before it is taken
# (see flowvo.odometry.road_length): real KITTI's level camera reads 0.0-1.0 degrees of pitch and 0.2-0.7 of roll, and
# a mounting taken must not be followed by another
MAX_ALIKE_SPREAD_DEG = 2.0  # the candidates' pitches (or rolls) must lean alike (inter-quartile range below this) for
# their median to be the mounting: the real dash-cam's scatter over 4.4 degrees (-6.5 to -2.1), and their median (-3.4,
# the horizon says -1.7) halved its speed when given as its pitch ([dashcam.md](dashcam.md))


def _spread_deg(angles_deg: list[float]) -> float | None:
    """The inter-quartile range of ``angles_deg`` (degrees); None before ``MIN_TILTED_FOR_HINT`` of them."""
    if len(angles_deg) < MIN_TILTED_FOR_HINT:
        return None
    low, high = np.percentile(angles_deg, [25, 75])
    return float(high - low)


def _alike_median_deg(angles_deg: list[float]) -> float:
    """The median of ``angles_deg`` (degrees) where they lean alike by ``MIN_HINT_DEG`` or more, else 0."""
    spread = _spread_deg(angles_deg)
    median = float(np.median(angles_deg))
    return median if spread is not None and spread < MAX_ALIKE_SPREAD_DEG and abs(median) >= MIN_HINT_DEG else 0.0


class RoadPlaneTally:
    """How the drive's candidate road planes fared: trusted, or refused as tilted, and the pitch and roll of every
    candidate (degrees, its normal's angle from the road's normal about the camera's x axis, positive when the
    camera looks further down than it was said to, and about its z axis, positive when the camera's right side
    is lower than it was said to be: :func:`flowvo.camera.mounting_rotation`). A camera pitched down or rolled but
    taken for level sees every road plane tilted by its mounting: most planes refused, their pitches and rolls
    alike. The mounting is estimated from all candidates, not from the refused ones alone (those lean by more than
    the gate by construction: advice from them never settled)."""

    def __init__(self) -> None:
        self.trusted = 0
        self.refused_as_tilted = 0
        self.pitches_deg: list[float] = []
        self.rolls_deg: list[float] = []
        self._since = (0, 0)  # (trusted, refused as tilted) when the pitches were last cleared (:meth:`restart`)
        self._taken = False  # a mounting was taken from the drive (:meth:`restart`)

    def add(self, plane: RoadPlane, trusted: bool, max_tilt_rad: float = MAX_ROAD_TILT_RAD) -> None:
        """Count a candidate plane (level frame) and whether it was trusted."""
        self.trusted += bool(trusted)
        self.refused_as_tilted += bool(not trusted and plane.tilt_rad > max_tilt_rad)
        self.pitches_deg.append(float(np.degrees(np.arctan2(plane.normal[2], plane.normal[1]))))
        self.rolls_deg.append(float(np.degrees(np.arctan2(plane.normal[0], plane.normal[1]))))

    def restart(self) -> None:
        """The camera's mounting changed (taken from the drive): it is estimated afresh from the candidates after
        now; the counts go on."""
        self.pitches_deg, self.rolls_deg = [], []
        self._since = (self.trusted, self.refused_as_tilted)
        self._taken = True

    def mounting_deg(self) -> tuple[float, float] | None:
        """The camera's pitch and roll relative to the ones given (degrees), the medians over every candidate plane;
        None before ``MIN_TILTED_FOR_HINT`` candidates."""
        if len(self.pitches_deg) < MIN_TILTED_FOR_HINT:
            return None
        return float(np.median(self.pitches_deg)), float(np.median(self.rolls_deg))

    def pitch_spread_deg(self) -> float | None:
        """The inter-quartile range of the candidates' pitches (degrees); None before ``MIN_TILTED_FOR_HINT``."""
        return _spread_deg(self.pitches_deg)

    def mounting_hint_deg(self) -> tuple[float, float] | None:
        """The pitch and roll to add to the ones given (degrees) when most candidate planes were refused as tilted,
        at least ``MIN_TILTED_FOR_HINT`` of them, or, once a mounting was taken from the drive, after as many
        candidates whatever became of them: each the candidates' median where they lean alike in it
        (``MAX_ALIKE_SPREAD_DEG``) by ``MIN_HINT_DEG`` or more, else 0; None when neither is (with the mounting taken,
        the candidates after it centre on the road and nothing more is taken). Planes refused but scattered say the
        road's flow is poor, not the mounting. A mounting taken is the drive's estimate, not the user's: where a
        stretch of road rolled against the camera (a rendered world's, synthetic 08: 2.7 degrees) gave it, the
        road after the stretch leans back by less than the gate, its planes trusted, and takes it back all the same."""
        trusted, refused = self.trusted - self._since[0], self.refused_as_tilted - self._since[1]
        if self._taken:
            if trusted + refused < MIN_TILTED_FOR_HINT:
                return None
        elif refused < MIN_TILTED_FOR_HINT or refused <= trusted:  # the counts first: asked after every candidate
            return None
        hint = tuple(_alike_median_deg(angles) for angles in (self.pitches_deg, self.rolls_deg))
        return None if hint == (0.0, 0.0) else hint

    def record(self) -> dict:
        """The tally as ``run.json`` records it."""
        mounting = self.mounting_deg()
        return {"trusted": self.trusted, "refused_as_tilted": self.refused_as_tilted,
                "candidates_median_pitch_deg": None if mounting is None else round(mounting[0], 2),
                "candidates_median_roll_deg": None if mounting is None else round(mounting[1], 2),
                "candidates_pitch_spread_deg": None if mounting is None else round(self.pitch_spread_deg(), 2)}


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
        """A trusted road plane gave the step at ``time_s`` (seconds)."""
        self.last_road_time_s = time_s

    def network_needed(self, time_s: float) -> bool:
        """True when the step at ``time_s`` should take the network's distance (and counts it)."""
        needed = time_s - self.last_road_time_s > self.after_s
        self.network_steps += needed
        return needed
