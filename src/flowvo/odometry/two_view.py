"""Two-view geometry: where to track, tracking, the motion up to scale (essential matrix) and triangulation.

Pure functions over NumPy arrays (OpenCV for tracking and the robust essential-matrix fit).
Frames: camera frame x right, y down, z forward; pixels of the frame the flow was computed at.
Motions are ``T_next_prev`` as OpenCV's ``recoverPose`` returns them: a point X in the first camera's
frame is ``R X + t`` in the second camera's frame.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from flowvo.geometry import cross, skew
from flowvo.odometry.numeric import row_norms, solved

TENSOR_BLOCK_PX = 3  # the structure tensor's window (5 px: synthetic replays 08-10 1.88 against 1.35 %)


def textured_points(image: np.ndarray, count: int = 600, cell_px: int = 8) -> np.ndarray:
    """Where to track the motion: the most corner-like pixel of each ``cell_px`` cell of ``image`` (H, W)
    uint8, the ``count`` strongest cells kept; (M, 2) float32 pixels, x right, y down.

    Corner-like: the smaller eigenvalue of the gradients' 3x3 structure tensor (Shi and Tomasi). Along a
    straight edge Lucas-Kanade slides, and the strongest gradient of a cell mostly lies on one: with it,
    half the tracks of real clip 01 did not return within 0.05 px when tracked back, and the chained
    rotations drifted (synthetic replays 08-10: 0.0077 deg/m against 0.0047 with corners).
    """
    h, w = image.shape
    magnitude = cv2.cornerMinEigenVal(image, TENSOR_BLOCK_PX, ksize=3)
    if image.min() == 0:  # the edge of an area without image would be tracked as a point that never moves
        magnitude[no_image_area(image)] = 0.0
    rows, cols = (h - 8) // cell_px, (w - 8) // cell_px
    cells = magnitude[4 : 4 + rows * cell_px, 4 : 4 + cols * cell_px]
    cells = cells.reshape(rows, cell_px, cols, cell_px).transpose(0, 2, 1, 3).reshape(rows, cols, -1)
    best = cells.argmax(axis=2)
    strength = cells.reshape(rows * cols, -1)[np.arange(rows * cols), best.ravel()]  # each cell's maximum
    order = np.argsort(strength)[::-1][:count]
    r, c = np.divmod(order, cols)
    b = best.ravel()[order]
    points = np.empty((len(order), 2), np.float32)
    points[:, 0] = 4 + c * cell_px + b % cell_px
    points[:, 1] = 4 + r * cell_px + b // cell_px
    return points


def no_image_area(image: np.ndarray, margin_px: int = 6) -> np.ndarray:
    """True (H, W) within ``margin_px`` of an area without image: black (0) regions larger than a single
    pixel, as the borders of undistorted, letterboxed or lens-warped frames (a dark real scene rarely
    reaches 0 over several pixels)."""
    black = (image == 0).astype(np.uint8)
    black = cv2.morphologyEx(black, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    return cv2.dilate(black, np.ones((2 * margin_px + 1, 2 * margin_px + 1), np.uint8)) > 0


def lucas_kanade(previous: np.ndarray, current: np.ndarray, points_px: np.ndarray, window_px: int = 15,
                 guess_px: np.ndarray | None = None, levels: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Pyramidal Lucas-Kanade with ``window_px`` square windows over ``levels`` pyramid levels above the frame:
    where ``points_px`` (N, 2) moved to, (N, 2) float32 pixels, and which were found, (N,) bool; searched from
    ``guess_px`` (N, 2) where given, else from where each point was."""
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 20, 0.03)
    start = points_px.reshape(-1, 1, 2).astype(np.float32)
    if not len(start):  # OpenCV returns None for no points
        return np.zeros((0, 2), np.float32), np.zeros(0, bool)
    guess = None if guess_px is None else guess_px.reshape(-1, 1, 2).astype(np.float32)  # a copy: OpenCV writes it
    moved, status, _ = cv2.calcOpticalFlowPyrLK(previous, current, start, guess, winSize=(window_px, window_px),
                                                maxLevel=levels, criteria=criteria,
                                                flags=0 if guess is None else cv2.OPTFLOW_USE_INITIAL_FLOW)
    return moved.reshape(-1, 2), status[:, 0] == 1


def track_points(previous: np.ndarray, current: np.ndarray, points_px: np.ndarray, window_px: int = 15
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Pyramidal Lucas-Kanade tracks of ``points_px`` (N, 2) (``window_px`` windows): the points that were
    found and where they moved to, each (M, 2) float32, pixels."""
    moved, found = lucas_kanade(previous, current, points_px, window_px)
    return points_px.reshape(-1, 2).astype(np.float32)[found], moved[found]


def track_points_checked(previous: np.ndarray, current: np.ndarray, points_px: np.ndarray,
                         max_return_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Lucas-Kanade tracks of ``points_px`` (N, 2) checked forward-backward: where each moved to, (N, 2)
    float32 pixels, and which are trustworthy, (N,) bool: found both ways, the backward track returning
    within ``max_return_px`` of the start (this rejects most tracks that slid along an edge or onto a
    compression block)."""
    moved, found = lucas_kanade(previous, current, points_px)
    back, found_back = lucas_kanade(current, previous, moved)
    returned = row_norms(back - points_px.reshape(-1, 2)) <= max_return_px
    return moved, found & found_back & returned


def follow_flow(points_px: np.ndarray, flow_px: np.ndarray) -> np.ndarray:
    """Where integer-pixel ``points_px`` (N, 2) land in the next frame by ``flow_px`` (H, W, 2)."""
    xs, ys = points_px[:, 0].astype(np.int64), points_px[:, 1].astype(np.int64)
    return points_px + flow_px[ys, xs]


@dataclass(frozen=True)
class EssentialMotion:
    """Rotation ``R_next_prev`` (3, 3), unit translation direction ``t_dir`` (3,) in the next frame,
    and the inlier mask (N,) of the correspondences."""

    R: np.ndarray
    t_dir: np.ndarray
    inliers: np.ndarray


def essential_motion(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray,
                     threshold_px: float = 0.5, min_inliers: int = 30,
                     robust_scale_px: float | None = None) -> EssentialMotion | None:
    """Motion up to scale from correspondences (N, 2) by USAC on the essential matrix; of the four
    decompositions, the one that puts most inliers in front of both cameras; with ``robust_scale_px``, refitted
    over its inliers (:func:`refined_motion`). None when the fit fails or keeps fewer than ``min_inliers``
    points."""
    if len(points_prev) < min_inliers:
        return None
    K = np.ascontiguousarray(K, dtype=np.float64)  # OpenCV's USAC reads a strided view (the left 3x3 of a
    # projection matrix) as its buffer: it silently finds no inliers
    cv2.setRNGSeed(0)  # the sampling, hence the result, must not depend on what ran before in this thread
    E, mask = cv2.findEssentialMat(points_prev, points_next, K, cv2.USAC_FAST, 0.999, threshold_px)
    if E is None or E.shape != (3, 3) or mask is None:
        return None
    inliers = mask[:, 0] > 0
    if inliers.sum() < min_inliers:
        return None
    R_a, R_b, t = cv2.decomposeEssentialMat(E)
    rays_prev, rays_next = _rays(points_prev[inliers], K), _rays(points_next[inliers], K)
    best, best_count = None, -1
    t_dir = t[:, 0] / np.linalg.norm(t[:, 0])
    for R in (R_a, R_b):
        depth_prev, depth_next = _depths(rays_prev, rays_next, EssentialMotion(R, t_dir, inliers))
        # the depths are linear in t: with -t they change sign, exactly
        for sign, count in ((1.0, ((depth_prev > 0) & (depth_next > 0)).sum()),
                            (-1.0, ((depth_prev < 0) & (depth_next < 0)).sum())):
            if count > best_count:
                best, best_count = EssentialMotion(R, sign * t_dir, inliers), int(count)
    if best_count < min_inliers:
        return None
    return best if robust_scale_px is None else _refitted(rays_prev, rays_next, K, best, robust_scale_px)


MAX_REFIT_RAD = np.radians(0.5)  # a robust refit that turns the rotation or the direction further is no small
# correction (a slow step's direction, poorly measured, moved 16 degrees on a synthetic replay): the fit stays


def refined_motion(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray, fit: EssentialMotion,
                   scale_px: float, reweightings: int = 10) -> EssentialMotion:
    """``fit`` with its rotation and direction refined over its inliers (correspondences (N, 2), pixels): the
    tracks' Sampson distances (pixels) weighted by Cauchy's ``1 / (1 + (d / scale_px)^2)``, by iteratively
    reweighted least squares (``reweightings`` solves) on their linearisation about the fit: a small rotation
    applied after ``R`` and a step of ``t`` orthogonal to it.

    USAC keeps every track within its threshold alike, and Lucas-Kanade's errors within it are not symmetric
    (the near road's stretching flow is measured short, far tracks have a one-sided tail): at 0.25 px they
    tilt the fit's pitch a few thousandths of a degree a step, always the same way. Weights that fall off well
    inside the threshold leave the fit to the tracks that agree closely. The numerator ``r2 . (t x R r1)`` is
    linear in both updates; the Sampson denominator is held at the fit (the update is a few thousandths of a
    degree: per pair on a synthetic replay, two linearisations of five reweightings each left the same pitch
    lean as one of ten, within 1e-5 degrees). ``fit`` itself where the refit would turn the rotation or the
    direction by more than ``MAX_REFIT_RAD``."""
    return _refitted(_rays(points_prev[fit.inliers], K), _rays(points_next[fit.inliers], K), K, fit, scale_px,
                     reweightings)


def _refitted(rays_prev: np.ndarray, rays_next: np.ndarray, K: np.ndarray, fit: EssentialMotion, scale_px: float,
              reweightings: int = 10) -> EssentialMotion:
    """:func:`refined_motion` on the viewing rays (M, 3) of the fit's inliers (:func:`essential_motion` has
    them from its cheirality check)."""
    R, t = fit.R, fit.t_dir
    rotated = rays_prev @ R.T  # R r1
    t_cross = skew(t)
    line_next = rotated @ t_cross.T  # E r1: the epipolar line in the second camera's normalised coordinates
    line_prev = rays_next @ (t_cross @ R)  # E^T r2
    inverse_focal_sq = np.array([1.0 / K[0, 0] ** 2, 1.0 / K[1, 1] ** 2])
    denominator = np.sqrt(np.maximum((line_next[:, :2] ** 2 + line_prev[:, :2] ** 2) @ inverse_focal_sq, 1e-24))
    distance_px = (rays_next * line_next).sum(axis=1) / denominator
    side = np.array([0.0, t[2], -t[1]]) if abs(t[0]) < 0.9 else np.array([-t[2], 0.0, t[0]])  # t x x or t x y
    side /= np.linalg.norm(side)
    basis = np.stack([side, t_cross @ side])  # unit vectors orthogonal to t
    jacobian = np.empty((len(rotated), 5))
    jacobian[:, :3] = (rotated @ t)[:, None] * rays_next - (rays_next * rotated).sum(axis=1)[:, None] * t
    jacobian[:, 3:] = cross(rotated, rays_next) @ basis.T  # r2 . (b x R r1) = (R r1 x r2) . b
    jacobian /= denominator[:, None]
    update = np.zeros(5)
    weighted = np.empty_like(jacobian)
    for _ in range(reweightings):  # in place, and LAPACK's solver called directly: 0.3 -> 0.2 ms a fit
        weight = jacobian @ update
        weight += distance_px
        weight /= scale_px
        weight *= weight
        weight += 1.0
        np.divide(jacobian, weight[:, None], out=weighted)
        update = solved(weighted.T @ jacobian, -(weighted.T @ distance_px))
    if max(np.linalg.norm(update[:3]), np.linalg.norm(update[3:])) > MAX_REFIT_RAD:
        return fit
    t = t + update[3] * basis[0] + update[4] * basis[1]
    return EssentialMotion(cv2.Rodrigues(update[:3])[0] @ R, t / np.linalg.norm(t), fit.inliers)


def motion_along(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray, direction: np.ndarray,
                 R_start: np.ndarray, threshold_px: float = 0.5, min_inliers: int = 30,
                 hypotheses: int = 200) -> EssentialMotion | None:
    """The motion with a given direction of travel ``direction`` (unit, first camera's frame) that best explains
    correspondences (N, 2): its rotation ``R_next_prev`` by RANSAC, then least squares on the inliers. A track's
    residual is its distance to its epipolar line in the second image (pixels); inliers lie within
    ``threshold_px`` (tracks with a non-finite position never). Each of ``hypotheses`` rotations solves three
    random tracks' epipolar constraints, linear in a small rotation about ``R_start`` (two Gauss-Newton steps);
    the one with most inliers wins (a local fit from ``R_start`` alone can settle on a second motion in view).
    Deterministic. None when fewer than ``min_inliers`` remain.

    With ``t = -R d`` the essential matrix is ``[t]x R = -R [d]x``: a track's epipolar line in the second image is
    ``K^-T R (d x r1)``, and the constraint ``r2 . R (d x r1) = 0`` is linear in a small rotation ``w`` applied
    after ``R``: ``r2 . m + w . (m x r2) = 0`` with ``m = R (d x r1)``.
    """
    usable = np.isfinite(points_prev).all(axis=1) & np.isfinite(points_next).all(axis=1)
    if usable.sum() < min_inliers:
        return None
    normals = cross(direction, _rays(points_prev, K))  # of the epipolar planes, first camera's frame
    next_px = np.ones((len(points_next), 3))
    next_px[:, :2] = points_next
    inverse_K = inverse_intrinsics(K)
    next_rays = next_px @ inverse_K.T

    def distances_px(rotations: np.ndarray) -> np.ndarray:
        """Each track's signed distance to its epipolar line (..., N) under rotations (..., 3, 3)."""
        lines = np.matmul(np.matmul(normals, np.swapaxes(rotations, -1, -2)), inverse_K)  # second image's pixels
        return (lines * next_px).sum(axis=-1) / np.maximum(np.hypot(lines[..., 0], lines[..., 1]), 1e-12)

    usable_rows = np.flatnonzero(usable)
    samples = np.random.default_rng(0).random((hypotheses, len(usable_rows))).argsort(axis=1)[:, :3]
    samples = usable_rows[samples]  # (H, 3) distinct tracks
    rotations = np.broadcast_to(R_start, (hypotheses, 3, 3))
    for _ in range(2):
        m = np.einsum("hkj,hsj->hsk", rotations, normals[samples])  # R (d x r1), (H, 3, 3)
        jacobian = cross(m, next_rays[samples])  # (H, 3 tracks, 3)
        residual = np.einsum("hsk,hsk->hs", m, next_rays[samples])
        solvable = np.abs(np.linalg.det(jacobian)) > 1e-12
        update = np.zeros((hypotheses, 3))
        update[solvable] = np.linalg.solve(jacobian[solvable], -residual[solvable][..., None])[..., 0]
        rotations = Rotation.from_rotvec(update).as_matrix() @ rotations
    counts = ((np.abs(distances_px(rotations)) <= threshold_px) & usable).sum(axis=1)
    R = rotations[int(np.argmax(counts))]
    for _ in range(2):  # least squares on the inliers, which are then chosen again
        inliers = usable & (np.abs(distances_px(R)) <= threshold_px)
        if inliers.sum() < min_inliers:
            return None
        R = _least_squares_rotation(distances_px, R, inliers)
    inliers = usable & (np.abs(distances_px(R)) <= threshold_px)
    if inliers.sum() < min_inliers:
        return None
    return EssentialMotion(R, -R @ direction, inliers)


def direction_given_rotation(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray, R: np.ndarray,
                             near: np.ndarray) -> np.ndarray:
    """The unit translation direction ``t`` (second camera's frame) that, with the rotation ``R``
    (``R_next_prev``), best explains correspondences (N, 2): least squares of each track's distance to its
    epipolar line (pixels), the lines' scale taken from ``near`` (a unit direction close to the answer), which
    also gives the sign. The constraint ``r2 . (t x R r1) = t . (R r1 x r2) = 0`` is linear in ``t``."""
    rotated = _rays(points_prev, K) @ R.T
    normals = cross(rotated, _rays(points_next, K))  # t . normal: the line's value at the second point
    lines = cross(near, rotated) @ inverse_intrinsics(K)
    weighted = normals / np.maximum(np.hypot(lines[:, 0], lines[:, 1]), 1e-12)[:, None]  # rows in pixels
    t = np.linalg.svd(weighted, full_matrices=False)[2][-1]
    return t if t @ near >= 0 else -t


def _least_squares_rotation(residuals: Callable[[np.ndarray], np.ndarray], R: np.ndarray, rows: np.ndarray
                            ) -> np.ndarray:
    """The rotation near ``R`` (a small rotation applied after it) that minimises the squares of
    ``residuals(rotation)[rows]``."""
    update = least_squares(lambda u: residuals(Rotation.from_rotvec(u).as_matrix() @ R)[rows], np.zeros(3)).x
    return Rotation.from_rotvec(update).as_matrix() @ R


def _rays(points_px: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Viewing rays (N, 3) with z = 1 of pixels (N, 2)."""
    homogeneous = np.ones((len(points_px), 3))
    homogeneous[:, :2] = points_px
    return homogeneous @ inverse_intrinsics(K).T


def inverse_intrinsics(K: np.ndarray) -> np.ndarray:
    """The inverse of the 3x3 intrinsics ``K`` (read-only; a drive has one camera: inverted once, not at each of
    the ~14 ray computations and homographies of a frame)."""
    return _inverse_of(np.ascontiguousarray(K, dtype=np.float64).tobytes())


@functools.lru_cache(maxsize=8)
def _inverse_of(K_bytes: bytes) -> np.ndarray:
    """:func:`inverse_intrinsics` of the 3x3 float64 intrinsics given as bytes."""
    inverse = np.linalg.inv(np.frombuffer(K_bytes).reshape(3, 3))
    inverse.flags.writeable = False
    return inverse


def translation_parallax_px(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray,
                            R: np.ndarray) -> np.ndarray:
    """How far each point (N, 2) moved beyond what the rotation ``R`` (``R_next_prev``) alone explains,
    pixels (N,): the part of the motion that carries depth."""
    rotated = _rays(points_prev, K) @ R.T @ K.T
    with np.errstate(divide="ignore", invalid="ignore"):
        rotated_px = rotated[:, :2] / rotated[:, 2:3]
    return row_norms(points_next - rotated_px)


def pair_depths(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray, motion: EssentialMotion
                ) -> tuple[np.ndarray, np.ndarray]:
    """Depths (z, N each) of correspondences (N, 2) in the first and in the second camera, in units of the
    step length (midpoint method)."""
    return _depths(_rays(points_prev, K), _rays(points_next, K), motion)


def _depths(rays_prev: np.ndarray, rays_next: np.ndarray, motion: EssentialMotion
            ) -> tuple[np.ndarray, np.ndarray]:
    """Depths along the rays (N, 3) of both cameras (midpoint method), in units of the step length.

    With rays ``u = R r1`` and ``v = r2`` (second camera's frame) and ``X2 = R X1 + t``, the depths
    ``l1, l2`` minimise ``|l1 u + t - l2 v|^2``: a 2x2 linear system per point, solved in closed form.
    """
    u = rays_prev @ motion.R.T
    v = rays_next
    t = motion.t_dir
    uu, vv, uv = (np.einsum("ij,ij->i", a, b) for a, b in ((u, u), (v, v), (u, v)))
    ut, vt = u @ t, v @ t
    determinant = np.maximum(uu * vv - uv * uv, 1e-18)
    return (-ut * vv + uv * vt) / determinant, (uu * vt - uv * ut) / determinant


def triangulate(points_prev: np.ndarray, points_next: np.ndarray, K: np.ndarray, motion: EssentialMotion
                ) -> np.ndarray:
    """3-D points (N, 3) in the first camera's frame, in units of the step length (midpoint method)."""
    rays_prev = _rays(points_prev, K)
    depth_prev, _ = _depths(rays_prev, _rays(points_next, K), motion)
    return rays_prev * depth_prev[:, None]


def se3_next_prev(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The 4x4 transform ``[R | t]``."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T
