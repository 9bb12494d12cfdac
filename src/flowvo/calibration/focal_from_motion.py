"""The focal length of an uncalibrated camera from its own motion (self-calibration), or why it cannot be had.

Model: square pixels (``fx = fy = f``), the principal point at the image centre ``((w - 1) / 2, (h - 1) / 2)``,
no lens distortion. Input: correspondences between frame pairs (:mod:`flowvo.calibration.motion_pairs`).

Cost: for a candidate ``f`` each pair gets its own motion (rotation ``R``, translation direction ``t``,
``X2 = R X1 + t``), fitted to its points by robust least squares (Cauchy loss, ``COST_SCALE_PX``); the
residual of a point is its distance in the second frame, pixels, to where the point could be seen from the
first frame at any depth in front of the camera: the segment from its vanishing point (infinitely far) to
the epipole (the second camera's centre). The epipolar (Sampson) distance uses only the distance across
the epipolar line; the segment also charges points seen "beyond infinity", which is what ties the rotation
to ``f`` where points are far away (a motorway: the epipolar cost alone missed the focal length of KITTI
clip 01 by 14-34 %). The estimate minimises the sum over pairs: a log-spaced grid over
``SEARCH_RANGE_WIDTHS`` then a fine grid around its best, interpolated by a parabola in log f.

Why turns matter: for a camera moving straight ahead every ``f`` explains the motion equally (the essential
matrix of a pure translation keeps its form under any change of ``f``); what pins ``f`` down grows with the
square of the sine of the rotation between the two frames. A pair turning by less than
``MIN_PAIR_ROTATION_DEG`` is left out; no such pair, or an estimate that moves by more than
``MAX_RELATIVE_UNCERTAINTY`` when the pairs are resampled, is reported as not observable.

Uncertainty (1 sigma, relative): the spread of the estimate over a moving-block bootstrap of the pairs
(blocks of overlapping pairs, which share frames and tracks), combined with ``PRINCIPAL_POINT_UNCERTAINTY``
for the model itself: a real principal point is seldom exactly at the centre, and the bootstrap cannot
see that error (it is the same in every pair).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from flowvo.calibration.motion_pairs import PointPair
from flowvo.methods.base import REFERENCE_WIDTH_PX  # the pixel thresholds below are set at this width
from flowvo.odometry.two_view import essential_motion
from flowvo.progress import progress

SEARCH_RANGE_WIDTHS = (0.3, 3.0)  # focal lengths searched, in image widths: 118 deg to 19 deg field of view
COARSE_STEP = 1.1  # ratio between neighbouring focal lengths of the first grid
FINE_SPAN = 0.1  # the fine grid covers the coarse best * exp(+-FINE_SPAN) ...
FINE_STEPS = 21  # ... in this many steps (1 % apart)
NOMINAL_FOCAL_WIDTHS = 0.7  # a middle-of-the-road focal length (65 deg field of view), in image widths: for
# the pair rotations that decide which pairs take part, and as the grid sweep's start
MIN_PAIR_ROTATION_DEG = 3.0  # pairs turning less carry no information on f (sin^2 of 3 deg: 0.3 %)
FUNDAMENTAL_THRESHOLD_PX = 1.0  # at the reference width: outliers of the f-free fundamental-matrix fit are dropped
ESSENTIAL_THRESHOLD_PX = 1.0  # at the reference width: inlier threshold of the starting motion of each pair
COST_SCALE_PX = 0.5  # at the reference width: the Cauchy loss's scale, about the tracking noise of compressed video
MIN_PAIRS = 3  # fewer turning pairs than this: no estimate (one turn seen from three angles at least)
MAX_RELATIVE_UNCERTAINTY = 0.1  # bootstrap spread beyond +-10 % (1 sigma): the estimate is not worth reporting
PRINCIPAL_POINT_UNCERTAINTY = 0.02  # relative error of f from the principal point taken at the centre: the
# KITTI clips (1 % of the width off centre) and synthetic drives (the same offset) were 0.3-3.9 % off, 2.6 % RMS
BOOTSTRAP_SAMPLES = 200  # resamplings of the pairs for the uncertainty
LM_ITERATIONS = 20  # per focal length; each starts from the neighbouring focal length's motions
LM_STEP = 1e-6  # finite-difference step of the Jacobian (radians; unit translation)
LM_INITIAL_DAMPING, LM_MIN_DAMPING, LM_MAX_DAMPING = 1e-3, 1e-9, 1e6  # Levenberg-Marquardt, relative

_Motions = tuple[np.ndarray, np.ndarray]  # rotations (P, 3, 3) and unit translations (P, 3) of P pairs


@dataclass(frozen=True)
class FocalEstimate:
    """The result: ``focal_px`` (fx = fy, pixels of the frames given) and its 1-sigma
    ``relative_uncertainty`` (0.02: +-2 %; the bootstrap's part alone: ``bootstrap_uncertainty``) when
    ``observable``, else None and the ``reason`` in one sentence; ``pairs_used``: turning frame pairs that
    took part; ``max_rotation_deg``: the largest rotation within a pair (at the nominal focal length)."""

    focal_px: float | None
    relative_uncertainty: float | None
    pairs_used: int
    observable: bool
    reason: str
    max_rotation_deg: float
    bootstrap_uncertainty: float | None = None

    def scaled(self, factor: float) -> FocalEstimate:
        """The estimate for the frames resized by ``factor`` (the focal length scales, nothing else)."""
        return replace(self, focal_px=None if self.focal_px is None else self.focal_px * factor)

    def record(self) -> dict:
        """The estimate as ``run.json`` records it."""
        return {"focal_px": self.focal_px, "relative_uncertainty": self.relative_uncertainty,
                "bootstrap_uncertainty": self.bootstrap_uncertainty, "pairs_used": self.pairs_used,
                "observable": self.observable, "reason": self.reason, "max_rotation_deg": self.max_rotation_deg}


def principal_point(image_size_hw: tuple[int, int]) -> tuple[float, float]:
    """The image centre ``(cx, cy)``, pixels: where the model puts the principal point."""
    h, w = image_size_hw
    return (w - 1) / 2.0, (h - 1) / 2.0


def estimate_focal(pairs: Sequence[PointPair], image_size_hw: tuple[int, int]) -> FocalEstimate:
    """The focal length that best explains every pair's motion, or why it cannot be determined (see the
    module docstring). Deterministic."""
    w = image_size_hw[1]
    scale = w / REFERENCE_WIDTH_PX
    centre = principal_point(image_size_hw)
    nominal = NOMINAL_FOCAL_WIDTHS * w
    if not pairs:
        return FocalEstimate(None, None, 0, False, "no two frames share enough tracked points that moved (the "
                             "camera stands still, or the frames are too small or too plain to track)", 0.0)
    turning, motions, max_rotation_deg = _turning_pairs(pairs, centre, nominal, scale)
    if len(turning) < MIN_PAIRS:
        return FocalEstimate(None, None, len(turning), False,
                             f"the camera turns too little: at most {max_rotation_deg:.1f} deg between the frames of "
                             f"a pair, and {len(turning)} pair(s) turn by {MIN_PAIR_ROTATION_DEG:g} deg or more "
                             f"({MIN_PAIRS} needed)", max_rotation_deg)
    problem = _Problem(turning, centre, COST_SCALE_PX * scale)
    low, high = (factor * w for factor in SEARCH_RANGE_WIDTHS)
    coarse = np.exp(np.arange(math.log(low), math.log(high) + 1e-9, math.log(COARSE_STEP)))
    coarse_costs, coarse_motions = problem.profile(coarse, nominal, motions)
    best = int(np.argmin(coarse_costs.sum(axis=1)))
    if best in (0, len(coarse) - 1):
        return FocalEstimate(None, None, len(turning), False,
                             f"the motion fits best at the edge of the searched {low:.0f}-{high:.0f} px: no focal "
                             "length explains it", max_rotation_deg)
    fine = coarse[best] * np.exp(np.linspace(-FINE_SPAN, FINE_SPAN, FINE_STEPS))
    fine_costs, _ = problem.profile(fine, coarse[best], coarse_motions[best])
    outside = np.abs(np.log(coarse / coarse[best])) > FINE_SPAN
    focals = np.concatenate([coarse[outside], fine])
    costs = np.concatenate([coarse_costs[outside], fine_costs])
    order = np.argsort(focals)
    focals, costs = focals[order], costs[order]
    focal_px = _parabola_minimum(focals, costs.sum(axis=1))
    samples = np.array([_parabola_minimum(focals, costs[:, choice].sum(axis=1))
                        for choice in _block_bootstrap(turning)])
    spread = float(np.std(np.log(samples)))
    if spread > MAX_RELATIVE_UNCERTAINTY:
        return FocalEstimate(None, None, len(turning), False,
                             f"the motion fits a wide range of focal lengths (+-{100 * spread:.0f} % at 1 sigma, "
                             f"best {focal_px:.0f} px)", max_rotation_deg, spread)
    return FocalEstimate(focal_px, math.hypot(spread, PRINCIPAL_POINT_UNCERTAINTY), len(turning), True, "",
                         max_rotation_deg, spread)


def _turning_pairs(pairs: Sequence[PointPair], centre: tuple[float, float], nominal_px: float, scale: float
                   ) -> tuple[list[PointPair], _Motions, float]:
    """The pairs that turn by ``MIN_PAIR_ROTATION_DEG`` or more at the nominal focal length, reduced to the
    inliers of their fundamental matrix, with their motions there; and the largest rotation of any pair,
    degrees."""
    K = _camera_matrix(nominal_px, centre)
    turning, rotations, translations, max_rotation_deg = [], [], [], 0.0
    for pair in pairs:
        cv2.setRNGSeed(0)  # deterministic sampling
        F, mask = cv2.findFundamentalMat(pair.first_px, pair.second_px, cv2.USAC_MAGSAC,
                                         FUNDAMENTAL_THRESHOLD_PX * scale, 0.999)
        if F is None or mask is None:
            continue
        inliers = mask[:, 0] > 0
        motion = essential_motion(pair.first_px[inliers], pair.second_px[inliers], K,
                                  ESSENTIAL_THRESHOLD_PX * scale)
        if motion is None:
            continue
        rotation_deg = float(np.degrees(Rotation.from_matrix(motion.R).magnitude()))
        max_rotation_deg = max(max_rotation_deg, rotation_deg)
        if rotation_deg >= MIN_PAIR_ROTATION_DEG:
            turning.append(PointPair(pair.first, pair.second, pair.first_px[inliers], pair.second_px[inliers]))
            rotations.append(motion.R)
            translations.append(motion.t_dir)
    return turning, (np.array(rotations), np.array(translations)), max_rotation_deg


def _camera_matrix(focal_px: float, centre: tuple[float, float]) -> np.ndarray:
    return np.array([[focal_px, 0.0, centre[0]], [0.0, focal_px, centre[1]], [0.0, 0.0, 1.0]])


class _Problem:
    """The pairs' points, stacked, and their motions, fitted for one candidate focal length after another
    (each fit starts from the previous one's motions)."""

    def __init__(self, pairs: Sequence[PointPair], centre: tuple[float, float], cost_scale_px: float) -> None:
        self.pairs = pairs
        self.centre = np.asarray(centre)
        self.cost_scale_px = cost_scale_px
        self.first_px = np.concatenate([p.first_px for p in pairs]).astype(np.float64)
        self.second_px = np.concatenate([p.second_px for p in pairs]).astype(np.float64)
        counts = [len(p.first_px) for p in pairs]
        self.pair_of_point = np.repeat(np.arange(len(pairs)), counts)
        self.starts = np.concatenate([[0], np.cumsum(counts)[:-1]])

    def profile(self, focals_px: np.ndarray, start_px: float, motions: _Motions
                ) -> tuple[np.ndarray, list[_Motions]]:
        """Each pair's robust cost (len(focals), pairs) at each focal length and the motions fitted there;
        swept outwards from the focal length nearest ``start_px``, whose fit starts from ``motions`` (each
        later fit starts from its neighbour's)."""
        costs = np.zeros((len(focals_px), len(self.pairs)))
        fitted: list[_Motions] = [motions] * len(focals_px)
        first = int(np.argmin(np.abs(np.log(focals_px / start_px))))
        order = [*range(first, len(focals_px)), *range(first - 1, -1, -1)]
        for i in progress(order, "fitting the focal length", len(order), "focal length"):
            neighbour = i - 1 if i > first else i + 1  # fitted just before, on the side of the first
            start, start_at_px = (motions, start_px) if i == first else (fitted[neighbour], focals_px[neighbour])
            fitted[i], costs[i] = self._fit(focals_px[i], _rescaled(start, start_at_px / focals_px[i]))
        return costs, fitted

    def _fit(self, focal_px: float, motions: _Motions) -> tuple[_Motions, np.ndarray]:
        """The pairs' motions at ``focal_px``, refined from ``motions``, and each pair's robust cost.

        Levenberg-Marquardt on all pairs at once (each pair its own 5x5 system: a rotation vector and a step
        in the plane normal to its translation), iteratively reweighted for the Cauchy loss; a step is kept
        per pair where it lowers that pair's cost. Finite-difference Jacobians (the segment's clamp makes
        the residual only piecewise smooth)."""
        rays_first = np.c_[(self.first_px - self.centre) / focal_px, np.ones(len(self.first_px))]
        seen_second = (self.second_px - self.centre) / focal_px
        n_pairs = len(self.pairs)

        def offsets_px(m: _Motions) -> np.ndarray:
            return focal_px * _segment_offsets(rays_first, seen_second, *m, self.pair_of_point)

        rotations, translations = motions
        current = offsets_px((rotations, translations))
        costs = self._pair_costs(current)
        damping = np.full(n_pairs, LM_INITIAL_DAMPING)
        for _ in range(LM_ITERATIONS):
            basis = np.linalg.svd(translations[:, None, :])[2][:, 1:, :]  # (P, 2, 3): normal to each t
            jacobian = np.stack([(offsets_px(_moved((rotations, translations), basis, column)) - current)
                                 / LM_STEP for column in np.eye(5) * LM_STEP], axis=-1)  # (N, 2, 5)
            weights = 1.0 / (1.0 + (current / self.cost_scale_px) ** 2)  # IRLS weights of the Cauchy loss
            normal = np.add.reduceat(np.einsum("nc,nci,ncj->nij", weights, jacobian, jacobian), self.starts)
            gradient = np.add.reduceat(np.einsum("nc,nci,nc->ni", weights, jacobian, current), self.starts)
            diagonal = np.einsum("pii->pi", normal)
            step = -np.linalg.solve(normal + (damping[:, None] * diagonal + 1e-12)[:, :, None] * np.eye(5),
                                    gradient[:, :, None])[:, :, 0]
            trial = _moved((rotations, translations), basis, step)
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


def _rescaled(motions: _Motions, ratio: float) -> _Motions:
    """Motions for a focal length 1 / ``ratio`` times the one ``motions`` were fitted at, moving the image
    points about as much: rotation angles and the epipole's offset from the centre scaled by ``ratio``
    (small-angle approximation: a good start for the refit)."""
    rotations, translations = motions
    rotvecs = Rotation.from_matrix(rotations).as_rotvec() * ratio
    translations = np.c_[translations[:, :2] * ratio, translations[:, 2:]]
    return Rotation.from_rotvec(rotvecs).as_matrix(), translations / np.linalg.norm(translations, axis=1,
                                                                                    keepdims=True)


def _moved(motions: _Motions, basis: np.ndarray, step: np.ndarray) -> _Motions:
    """Motions moved by ``step`` (P, 5) or (5,) for every pair: a rotation vector applied on the left and a
    step of the translation in its normal plane (``basis`` (P, 2, 3)), renormalised."""
    rotations, translations = motions
    step = np.broadcast_to(step, (len(rotations), 5)).copy()
    rotations = Rotation.from_rotvec(step[:, :3]).as_matrix() @ rotations
    translations = translations + np.einsum("pk,pkj->pj", step[:, 3:], basis)
    return rotations, translations / np.linalg.norm(translations, axis=1, keepdims=True)


def _segment_offsets(rays_first: np.ndarray, seen_second: np.ndarray, rotations: np.ndarray,
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


def _parabola_minimum(x: np.ndarray, y: np.ndarray) -> float:
    """The minimum of the parabola in log x through the lowest sample of ``y`` and its two neighbours (the
    lowest sample itself at an end). Only the nearest samples: the profile is lopsided (a focal length too
    short puts far points beyond infinity, which costs more than one too long), and a wider fit would
    follow the lopsidedness (+1 % on exact correspondences)."""
    i = int(np.argmin(y))
    if i in (0, len(x) - 1):
        return float(x[i])
    u = np.log(x[i - 1 : i + 2]) - math.log(x[i])
    a, b, _ = np.polyfit(u, y[i - 1 : i + 2], 2)
    if a <= 0:
        return float(x[i])
    return float(x[i] * math.exp(np.clip(-b / (2 * a), u[0], u[2])))


def _block_bootstrap(pairs: Sequence[PointPair]) -> list[np.ndarray]:
    """``BOOTSTRAP_SAMPLES`` resamplings (indices) of the pairs in circular blocks as long as the number of
    pairs that share a frame with a pair, on average (deterministic seed)."""
    n = len(pairs)
    spans = [(p.first, p.second) for p in pairs]
    overlaps = [sum(1 for a, b in spans if a <= second and b >= first) for first, second in spans]
    block = max(1, min(n, round(float(np.mean(overlaps)))))
    rng = np.random.default_rng(0)
    blocks = -(-n // block)
    samples = []
    for _ in range(BOOTSTRAP_SAMPLES):
        starts = rng.integers(0, n, blocks)
        samples.append(((starts[:, None] + np.arange(block)) % n).ravel()[:n])
    return samples
