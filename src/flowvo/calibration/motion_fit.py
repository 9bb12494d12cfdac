"""Each frame pair's motion fitted for a candidate camera, and how well it then explains the pair's points:
the cost :mod:`flowvo.calibration.focal_from_motion` minimises over the focal length and the lens.

A candidate camera is a focal length ``f`` (square pixels, the principal point at the image centre) and a
lens (:class:`DivisionLens`, or a given one, :class:`GivenLens`). For it, each pair gets its own motion
(rotation ``R``, translation direction ``t``, ``X2 = R X1 + t``), fitted to its points by robust least
squares (Cauchy loss). The residual of a point is its distance in the second frame to where the point could
be seen from the first frame at any depth in front of the camera: the segment from its vanishing point
(infinitely far) to the epipole (the second camera's centre), measured in the undistorted image and mapped
back to pixels of the frame as seen through the lens (the lens's local Jacobian), so a lens that stretches
the periphery is not charged for stretching its noise. Pure functions over NumPy arrays; pixels of the
frames given (x right, y down).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from flowvo.calibration.motion_pairs import PointPair
from flowvo.camera import CameraIntrinsics, LensDistortion, undistort_points
from flowvo.progress import progress

LM_ITERATIONS = 20  # per candidate camera; each starts from the neighbouring candidate's motions
LM_STEP = 1e-6  # finite-difference step of the Jacobian (radians; unit translation)
LM_INITIAL_DAMPING, LM_MIN_DAMPING, LM_MAX_DAMPING = 1e-3, 1e-9, 1e6  # Levenberg-Marquardt, relative
JACOBIAN_STEP_PX = 0.5  # central differences of a lens's undistortion map
PLUMB_BOB_TOLERANCE_PX = 0.25  # a division lens is given as plumb-bob k1 k2 where they reproduce it this closely

Motions = tuple[np.ndarray, np.ndarray]  # rotations (P, 3, 3) and unit translations (P, 3) of P pairs


@dataclass(frozen=True)
class DivisionLens:
    """The one-parameter division model of radial distortion about the image centre (Fitzgibbon, CVPR
    2001): a point seen at ``d`` pixels from ``centre`` lies at ``d / (1 + lam |d|^2 / radius_px^2)`` in the
    undistorted (pinhole) image. ``radius_px``: the half diagonal of the frames, so ``lam`` is the relative
    stretch of a corner, whatever the focal length: -0.1 moves a corner seen 100 px from the centre to 111
    px (barrel distortion, wide-angle lenses), positive values pincushion; 0 is no distortion. It does not
    depend on the focal length: the undistorted image is the same for every candidate."""

    centre: tuple[float, float]
    radius_px: float
    lam: float = 0.0

    focal_dependent = False

    def undistort_px(self, points_px: np.ndarray, focal_px: float) -> np.ndarray:
        """Where points seen at ``points_px`` (N, 2) lie in the undistorted image, (N, 2) float64 pixels."""
        d = np.asarray(points_px, dtype=np.float64) - self.centre
        return self.centre + d / (1.0 + self.lam * (d**2).sum(axis=1, keepdims=True) / self.radius_px**2)

    @property
    def is_none(self) -> bool:
        return self.lam == 0.0

    def opencv_distortion(self, focal_px: float) -> LensDistortion:
        """The same lens for the focal length ``focal_px`` as OpenCV's coefficients (normalised image
        coordinates, what ``--dist`` takes): plumb-bob ``k1 k2 0 0`` where they reproduce it within
        ``PLUMB_BOB_TOLERANCE_PX`` over the frame (radii up to ``radius_px``), else the rational model (eight
        coefficients, within 0.01 px for coefficients down to -0.6); least squares over the radii."""
        if self.lam == 0.0:
            return LensDistortion()
        seen_px = np.linspace(0.0, self.radius_px, 400)[1:]
        undistorted_px = seen_px / (1.0 + self.lam * seen_px**2 / self.radius_px**2)
        s = (undistorted_px / focal_px) ** 2  # seen = undistorted * (1 + k1 s + k2 s^2 + ...) / (...)
        stretch = seen_px / undistorted_px
        (k1, k2), *_ = np.linalg.lstsq(np.c_[s, s**2] * undistorted_px[:, None], seen_px - undistorted_px, rcond=None)
        if np.abs(undistorted_px * (1 + k1 * s + k2 * s**2) - seen_px).max() <= PLUMB_BOB_TOLERANCE_PX:
            return LensDistortion("plumb_bob", (float(k1), float(k2), 0.0, 0.0))
        terms = np.c_[s, s**2, s**3, -stretch[:, None] * np.c_[s, s**2, s**3]]
        k1, k2, k3, k4, k5, k6 = np.linalg.lstsq(terms, stretch - 1.0, rcond=None)[0]
        return LensDistortion("rational_polynomial", tuple(float(k) for k in (k1, k2, 0.0, 0.0, k3, k4, k5, k6)))


@dataclass(frozen=True)
class GivenLens:
    """A lens the user gave (``--dist``): its coefficients are in normalised image coordinates, so where a
    point lies in the undistorted image depends on the candidate focal length."""

    centre: tuple[float, float]
    distortion: LensDistortion

    focal_dependent = True

    def undistort_px(self, points_px: np.ndarray, focal_px: float) -> np.ndarray:
        K = CameraIntrinsics(focal_px, focal_px, *self.centre).K
        return undistort_points(points_px, K, self.distortion).astype(np.float64)

    @property
    def is_none(self) -> bool:
        return self.distortion.is_none


Lens = DivisionLens | GivenLens


class PairFit:
    """The pairs' points, stacked, fitted for one candidate focal length after another through one lens
    (each fit starts from the previous one's motions). ``cost_scale_px``: the Cauchy loss's scale, pixels."""

    def __init__(self, pairs: Sequence[PointPair], lens: Lens, cost_scale_px: float) -> None:
        self.pairs = pairs
        self.lens = lens
        self.centre = np.asarray(lens.centre)
        self.cost_scale_px = cost_scale_px
        self.first_px = np.concatenate([p.first_px for p in pairs]).astype(np.float64)
        self.second_px = np.concatenate([p.second_px for p in pairs]).astype(np.float64)
        counts = [len(p.first_px) for p in pairs]
        self.pair_of_point = np.repeat(np.arange(len(pairs)), counts)
        self.starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        self._undistorted = None if lens.focal_dependent else self._undistorted_at(1.0)

    def profile(self, focals_px: np.ndarray, start_px: float, motions: Motions,
                label: str = "fitting the focal length") -> tuple[np.ndarray, list[Motions]]:
        """Each pair's robust cost (len(focals), pairs) at each focal length and the motions fitted there;
        swept outwards from the focal length nearest ``start_px``, whose fit starts from ``motions`` (fitted
        at ``start_px``; each later fit starts from its neighbour's)."""
        costs = np.zeros((len(focals_px), len(self.pairs)))
        fitted: list[Motions] = [motions] * len(focals_px)
        first = int(np.argmin(np.abs(np.log(focals_px / start_px))))
        order = [*range(first, len(focals_px)), *range(first - 1, -1, -1)]
        for i in progress(order, label, len(order), "focal length"):
            neighbour = i - 1 if i > first else i + 1  # fitted just before, on the side of the first
            start, start_at_px = (motions, start_px) if i == first else (fitted[neighbour], focals_px[neighbour])
            fitted[i], costs[i] = self.fit(focals_px[i], rescaled(start, start_at_px / focals_px[i]))
        return costs, fitted

    def _undistorted_at(self, focal_px: float) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """The points in the undistorted image and, per point of the second frames, the lens's Jacobian
        (N, 2, 2): pixels seen per undistorted pixel (None without distortion)."""
        first = self.lens.undistort_px(self.first_px, focal_px)
        second = self.lens.undistort_px(self.second_px, focal_px)
        if self.lens.is_none:
            return first, second, None
        h = JACOBIAN_STEP_PX
        columns = [(self.lens.undistort_px(self.second_px + step, focal_px)
                    - self.lens.undistort_px(self.second_px - step, focal_px)) / (2 * h)
                   for step in ((h, 0.0), (0.0, h))]
        return first, second, np.linalg.inv(np.stack(columns, axis=-1))

    def fit(self, focal_px: float, motions: Motions) -> tuple[Motions, np.ndarray]:
        """The pairs' motions at ``focal_px``, refined from ``motions``, and each pair's robust cost.

        Levenberg-Marquardt on all pairs at once (each pair its own 5x5 system: a rotation vector and a step
        in the plane normal to its translation), iteratively reweighted for the Cauchy loss; a step is kept
        per pair where it lowers that pair's cost. Finite-difference Jacobians (the segment's clamp makes
        the residual only piecewise smooth)."""
        first, second, seen_per_undistorted = self._undistorted or self._undistorted_at(focal_px)
        rays_first = np.c_[(first - self.centre) / focal_px, np.ones(len(first))]
        seen_second = (second - self.centre) / focal_px
        n_pairs = len(self.pairs)

        def offsets_px(m: Motions) -> np.ndarray:
            offsets = focal_px * segment_offsets(rays_first, seen_second, *m, self.pair_of_point)
            if seen_per_undistorted is None:
                return offsets
            return np.einsum("nij,nj->ni", seen_per_undistorted, offsets)

        rotations, translations = motions
        current = offsets_px((rotations, translations))
        costs = self._pair_costs(current)
        damping = np.full(n_pairs, LM_INITIAL_DAMPING)
        for _ in range(LM_ITERATIONS):
            basis = np.linalg.svd(translations[:, None, :])[2][:, 1:, :]  # (P, 2, 3): normal to each t
            jacobian = np.stack([(offsets_px(moved((rotations, translations), basis, column)) - current)
                                 / LM_STEP for column in np.eye(5) * LM_STEP], axis=-1)  # (N, 2, 5)
            weights = 1.0 / (1.0 + (current / self.cost_scale_px) ** 2)  # IRLS weights of the Cauchy loss
            normal = np.add.reduceat(np.einsum("nc,nci,ncj->nij", weights, jacobian, jacobian), self.starts)
            gradient = np.add.reduceat(np.einsum("nc,nci,nc->ni", weights, jacobian, current), self.starts)
            diagonal = np.einsum("pii->pi", normal)
            step = -np.linalg.solve(normal + (damping[:, None] * diagonal + 1e-12)[:, :, None] * np.eye(5),
                                    gradient[:, :, None])[:, :, 0]
            trial = moved((rotations, translations), basis, step)
            trial_offsets = offsets_px(trial)
            trial_costs = self._pair_costs(trial_offsets)
            better = trial_costs < costs
            rotations = np.where(better[:, None, None], trial[0], rotations)
            translations = np.where(better[:, None], trial[1], translations)
            current = np.where(better[self.pair_of_point, None], trial_offsets, current)
            costs = np.where(better, trial_costs, costs)
            damping = np.clip(np.where(better, damping / 10, damping * 10), LM_MIN_DAMPING, LM_MAX_DAMPING)
        return (rotations, translations), costs

    def _pair_costs(self, offsets_px: np.ndarray) -> np.ndarray:
        """Each pair's Cauchy cost of its points' offsets (N, 2), pixels."""
        return np.add.reduceat(np.log1p((offsets_px / self.cost_scale_px) ** 2).sum(axis=1), self.starts)


def rescaled(motions: Motions, ratio: float) -> Motions:
    """Motions for a focal length 1 / ``ratio`` times the one ``motions`` were fitted at, moving the image
    points about as much: rotation angles and the epipole's offset from the centre scaled by ``ratio``
    (small-angle approximation: a good start for the refit)."""
    rotations, translations = motions
    rotvecs = Rotation.from_matrix(rotations).as_rotvec() * ratio
    translations = np.c_[translations[:, :2] * ratio, translations[:, 2:]]
    return Rotation.from_rotvec(rotvecs).as_matrix(), translations / np.linalg.norm(translations, axis=1,
                                                                                    keepdims=True)


def moved(motions: Motions, basis: np.ndarray, step: np.ndarray) -> Motions:
    """Motions moved by ``step`` (P, 5) or (5,) for every pair: a rotation vector applied on the left and a
    step of the translation in its normal plane (``basis`` (P, 2, 3)), renormalised."""
    rotations, translations = motions
    step = np.broadcast_to(step, (len(rotations), 5)).copy()
    rotations = Rotation.from_rotvec(step[:, :3]).as_matrix() @ rotations
    translations = translations + np.einsum("pk,pkj->pj", step[:, 3:], basis)
    return rotations, translations / np.linalg.norm(translations, axis=1, keepdims=True)


def segment_offsets(rays_first: np.ndarray, seen_second: np.ndarray, rotations: np.ndarray,
                    translations: np.ndarray, pair_of_point: np.ndarray) -> np.ndarray:
    """Offsets (N, 2), normalised image coordinates of the second camera, from where each point is seen
    (``seen_second``) to the nearest place it could be seen at a depth in front of the first camera: the
    segment from its vanishing point to the epipole (a ray away from it when the camera moves backwards).

    ``rays_first`` (N, 3): viewing rays in the first camera (z = 1); ``rotations`` (P, 3, 3) and unit
    ``translations`` (P, 3) per pair (``X2 = R X1 + t``); ``pair_of_point`` (N,) indexes them. A point at
    inverse depth ``rho`` is seen at ``v + mu d`` with ``v`` the vanishing point, ``d = t_xy - t_z v`` and
    ``mu = rho / (z + rho t_z)`` running over [0, 1 / t_z) (t_z > 0) or [0, inf).
    """
    rotated = np.einsum("nij,nj->ni", rotations[pair_of_point], rays_first)
    vanishing = rotated[:, :2] / np.maximum(rotated[:, 2:], 1e-9)
    t = translations[pair_of_point]
    direction = t[:, :2] - t[:, 2:] * vanishing
    along = np.einsum("ni,ni->n", seen_second - vanishing, direction) / \
        np.maximum(np.einsum("ni,ni->n", direction, direction), 1e-18)
    t_z = t[:, 2]
    farthest = np.where(t_z > 1e-9, 1.0 / np.maximum(t_z, 1e-9), np.inf)
    along = np.clip(along, 0.0, farthest)
    return seen_second - vanishing - along[:, None] * direction


def robust_spread(values: np.ndarray) -> float:
    """Half the 16-84 percentile range (1 sigma of a normal distribution, not moved by a few outliers)."""
    low, high = np.percentile(values, [16, 84])
    return float(high - low) / 2.0


def block_bootstrap(pairs: Sequence[PointPair], samples_count: int) -> list[np.ndarray]:
    """``samples_count`` resamplings (indices) of the pairs in circular blocks as long as the number of
    pairs that share a frame with a pair, on average (deterministic seed)."""
    n = len(pairs)
    spans = [(p.first, p.second) for p in pairs]
    overlaps = [sum(1 for a, b in spans if a <= second and b >= first) for first, second in spans]
    block = max(1, min(n, round(float(np.mean(overlaps)))))
    rng = np.random.default_rng(0)
    blocks = -(-n // block)
    samples = []
    for _ in range(samples_count):
        starts = rng.integers(0, n, blocks)
        samples.append(((starts[:, None] + np.arange(block)) % n).ravel()[:n])
    return samples
