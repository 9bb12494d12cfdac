"""The focal length of an uncalibrated camera and its lens's distortion, from the camera's own motion
(self-calibration), or why they cannot be had.

Model: square pixels (``fx = fy = f``), the principal point at the image centre ``((w - 1) / 2, (h - 1) / 2)``,
and radial distortion by the one-parameter division model (:class:`~flowvo.calibration.motion_fit.DivisionLens`,
its coefficient ``lam``), unless the lens is given (then only ``f`` is estimated, through that lens). Input:
correspondences between frame pairs (:mod:`flowvo.calibration.motion_pairs`), without the parts of the frame
that do not move with the scene (a bonnet).

Cost (:mod:`flowvo.calibration.motion_fit`): for a candidate ``(f, lam)`` each pair gets its own motion, fitted
to its points by robust least squares; a point's residual is its distance, in pixels as seen, to where it
could be seen at any depth in front of the camera. The estimate minimises the sum over pairs.

Search: at ``lam = 0`` a log-spaced grid over ``SEARCH_RANGE_WIDTHS`` (10 % steps); then ``lam`` in steps of
``LAMBDA_STEP`` both ways, each with a short walk of the focal length from the previous ``lam``'s best, until
the cost rises out of ``LAMBDA_BAND``; then a fine grid of focal lengths (2 % steps) at each ``lam`` within the
band. The minimum: a parabola in log f at each ``lam``, then one over ``lam`` through the lowest three.
Distortion left out of the model is not harmless: a barrel lens makes the periphery move less in a turn,
which reads as a longer focal length (the real dash-cam of ``docs/uncalibrated.md``: 94 % too long).

Why turns matter: for a camera moving straight ahead every ``f`` explains the motion equally (the essential
matrix of a pure translation keeps its form under any change of ``f``); what pins ``f`` down grows with the
square of the sine of the rotation between the two frames. A pair turning by less than
``MIN_PAIR_ROTATION_DEG`` is left out; too few such pairs, or an uncertainty (below) beyond
``MAX_RELATIVE_UNCERTAINTY``, is reported as not observable.

Uncertainty (1 sigma of log f), three parts in quadrature: the spread of the estimate over a moving-block
bootstrap of the pairs (blocks of overlapping pairs, which share frames and tracks; half the 16-84 percentile
range, so that the few resamples that miss every turn do not decide it); and the model's own errors, which
the bootstrap cannot see (they are the same in every pair): how far the estimate moves when the principal
point moves by ``PRINCIPAL_POINT_SIGMA_WIDTHS``, and when the lens coefficient moves by ``LENS_MODEL_SHARE``
of itself (or by all of it, where a lens was taken as none).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from flowvo.calibration.motion_fit import (
    DivisionLens,
    GivenLens,
    Lens,
    Motions,
    PairFit,
    block_bootstrap,
    rescaled,
    robust_spread,
)
from flowvo.calibration.motion_pairs import PointPair, without_still_regions
from flowvo.camera import LensDistortion
from flowvo.methods.base import REFERENCE_WIDTH_PX  # the pixel thresholds below are set at this width
from flowvo.odometry.two_view import essential_motion

SEARCH_RANGE_WIDTHS = (0.3, 3.0)  # focal lengths searched, in image widths: 118 deg to 19 deg field of view
COARSE_STEP = 1.1  # ratio between neighbouring focal lengths of the first grid
FINE_SPAN = 0.1  # the fine grid covers the coarse best * exp(+-FINE_SPAN) ...
FINE_STEPS = 11  # ... in this many steps (2 % apart)
NOMINAL_FOCAL_WIDTHS = 0.7  # a middle-of-the-road focal length (65 deg field of view), in image widths: for
# the pair rotations that decide which pairs take part, and as the grid sweep's start
LAMBDA_RANGE = (-0.6, 0.2)  # division-model coefficients searched: corners stretched 2.5x (a strong barrel
# lens) to pulled in by a sixth (pincushion); the lens is refused beyond
LAMBDA_STEP = 0.05  # between the coefficients of the search
LAMBDA_BAND = 0.02  # coefficients whose best cost is within this share of the best get the fine grid
LAMBDA_NEGLIGIBLE = 0.03  # a lens that moves the corners by less (or by less than 2 sigma) is taken as none: the
# real KITTI clips (rectified frames) read -0.02..+0.01
MIN_PAIR_ROTATION_DEG = 3.0  # pairs turning less carry no information on f (sin^2 of 3 deg: 0.3 %)
FUNDAMENTAL_THRESHOLD_PX = 10.0  # at the reference width: gross outliers of the f-free fundamental-matrix fit
# are dropped (a pinhole fit: a tighter threshold drops the periphery of a distorted lens, the points that show
# the distortion; the robust cost copes with the rest)
ESSENTIAL_THRESHOLD_PX = 1.0  # at the reference width: inlier threshold of the starting motion of each pair (3 px
# started one pair of the real dash-cam at a 50 deg turn sideways, and its estimate went 84 % wrong with +-6 %)
COST_SCALE_PX = 0.5  # at the reference width: the Cauchy loss's scale, about the tracking noise of compressed video
MIN_PAIRS = 3  # fewer turning pairs than this: no estimate (one turn seen from three angles at least)
MAX_RELATIVE_UNCERTAINTY = 0.1  # beyond +-10 % (1 sigma; the bootstrap's part alone, or all): not worth reporting
PRINCIPAL_POINT_SIGMA_WIDTHS = 0.015  # how far a real principal point lies from the image centre, 1 sigma per
# axis, in image widths: KITTI's 0.1-1.1 %, the real dash-cam's 2.3-2.5 %
LENS_MODEL_SHARE = 0.2  # the division model's coefficient is taken as uncertain by this share of itself: a
# real lens is not a division model (projected points through plumb-bob lenses: 15 % off the best fit)
BOOTSTRAP_SAMPLES = 200  # resamplings of the pairs for the uncertainty
UNCERTAINTY_SOURCES = {"bootstrap": "the turns themselves (the pairs resampled)",
                       "principal_point": "where the principal point lies (taken at the image centre)",
                       "lens_model": "how far a real lens may differ from the one-coefficient lens model"}


@dataclass(frozen=True)
class FocalEstimate:
    """The result, in pixels of the frames as decoded: ``focal_px`` (fx = fy) and its 1-sigma
    ``relative_uncertainty`` (0.02: +-2 %; the bootstrap's part alone: ``bootstrap_uncertainty``) when
    ``observable``, else None and the ``reason`` in one sentence; ``pairs_used``: turning frame pairs that
    took part; ``max_rotation_deg``: the largest rotation within a pair (at the nominal focal length).

    The lens: ``lens_lambda``, the division-model coefficient (:class:`DivisionLens`, relative to
    ``radius_px``, the frames' half diagonal) with its 1-sigma ``lens_lambda_uncertainty``, when estimated
    (``lens_estimated``; None when the lens was given). ``still_share``: the part of the frame left out as
    not moving with the scene (a bonnet)."""

    focal_px: float | None
    relative_uncertainty: float | None
    pairs_used: int
    observable: bool
    reason: str
    max_rotation_deg: float
    bootstrap_uncertainty: float | None = None
    lens_lambda: float | None = None
    lens_lambda_uncertainty: float | None = None
    lens_estimated: bool = True
    radius_px: float | None = None
    still_share: float = 0.0
    uncertainty_parts: dict | None = None

    def scaled(self, factor: float) -> FocalEstimate:
        """The estimate for the frames resized by ``factor`` (the lengths scale, nothing else)."""
        return replace(self, focal_px=None if self.focal_px is None else self.focal_px * factor,
                       radius_px=None if self.radius_px is None else self.radius_px * factor)

    @property
    def distortion(self) -> LensDistortion:
        """The estimated lens as OpenCV's coefficients (what ``--dist`` takes: plumb-bob ``k1 k2 0 0``, or the
        rational model's eight where those do not reproduce it), none when no lens was estimated or it is not
        told apart from none (within 2 sigma of 0)."""
        if self.focal_px is None or self.lens_lambda is None or \
                abs(self.lens_lambda) <= 2 * (self.lens_lambda_uncertainty or 0.0):
            return LensDistortion()
        return DivisionLens((0.0, 0.0), self.radius_px, self.lens_lambda).opencv_distortion(self.focal_px)

    def record(self) -> dict:
        """The estimate as ``run.json`` records it."""
        lens = None
        if self.lens_lambda is not None:
            lens = {"model": "division", "lambda": self.lens_lambda, "lambda_uncertainty": self.lens_lambda_uncertainty,
                    "radius_px": self.radius_px, "distortion_model": self.distortion.model,
                    "distortion": list(self.distortion.coefficients)}
        return {"focal_px": self.focal_px, "relative_uncertainty": self.relative_uncertainty,
                "bootstrap_uncertainty": self.bootstrap_uncertainty, "pairs_used": self.pairs_used,
                "observable": self.observable, "reason": self.reason, "max_rotation_deg": self.max_rotation_deg,
                "uncertainty_parts": self.uncertainty_parts, "lens_estimated": self.lens_estimated, "lens": lens,
                "still_share": self.still_share}


def principal_point(image_size_hw: tuple[int, int]) -> tuple[float, float]:
    """The image centre ``(cx, cy)``, pixels: where the model puts the principal point."""
    h, w = image_size_hw
    return (w - 1) / 2.0, (h - 1) / 2.0


@dataclass
class _Slice:
    """The pairs' costs at one lens over focal lengths: ``focals_px`` (F,) ascending, ``costs`` (F, P) and the
    motions fitted at each."""

    lam: float
    focals_px: np.ndarray
    costs: np.ndarray
    motions: list[Motions]

    @property
    def best(self) -> int:
        return int(np.argmin(self.costs.sum(axis=1)))

    @property
    def best_cost(self) -> float:
        return float(self.costs.sum(axis=1).min())


def estimate_focal(pairs: Sequence[PointPair], image_size_hw: tuple[int, int],
                   distortion: LensDistortion | None = None, frame_scale: float = 1.0) -> FocalEstimate:
    """The focal length (and, unless ``distortion`` gives the lens, the lens's distortion) that best
    explain every pair's motion, or why they cannot be determined (see the module docstring).
    ``image_size_hw``: the frames the pairs' pixels are in; ``frame_scale``: the frames as decoded over
    those (the result and its messages are in pixels of the frames as decoded). Deterministic."""
    w = image_size_hw[1]
    scale = w / REFERENCE_WIDTH_PX
    centre = principal_point(image_size_hw)
    radius_px = math.hypot(*image_size_hw) / 2.0
    given = distortion is not None and not distortion.is_none

    def lens(lam: float) -> Lens:
        return GivenLens(centre, distortion) if given else DivisionLens(centre, radius_px, lam)

    def refused(reason: str, turning: int = 0, max_rotation_deg: float = 0.0, spread: float | None = None
                ) -> FocalEstimate:
        return FocalEstimate(None, None, turning, False, reason, max_rotation_deg, spread, lens_estimated=not given,
                             radius_px=radius_px * frame_scale, still_share=still_share)

    pairs, still_share = without_still_regions(list(pairs), image_size_hw, scale)
    if not pairs:
        return refused("no two frames share enough tracked points that moved (the camera stands still, or the "
                       "frames are too small or too plain to track)")
    nominal = NOMINAL_FOCAL_WIDTHS * w
    turning, motions, max_rotation_deg = _turning_pairs(pairs, lens(0.0), nominal, scale)
    if len(turning) < MIN_PAIRS:
        return refused(f"the camera turns too little: at most {max_rotation_deg:.1f} deg between the frames of a "
                       f"pair, and {len(turning)} pair(s) turn by {MIN_PAIR_ROTATION_DEG:g} deg or more "
                       f"({MIN_PAIRS} needed)", len(turning), max_rotation_deg)
    low, high = (factor * w for factor in SEARCH_RANGE_WIDTHS)
    grid = np.exp(np.arange(math.log(low), math.log(high) + 1e-9, math.log(COARSE_STEP)))
    cost_scale_px = COST_SCALE_PX * scale
    coarse = _lens_walk(turning, lens, grid, nominal, motions, cost_scale_px, estimate_lens=not given)
    best = min(coarse, key=lambda s: s.best_cost)
    frame_px = frame_scale
    if not given and not LAMBDA_RANGE[0] + 1e-9 < best.lam < LAMBDA_RANGE[1] - 1e-9:
        return refused(f"the lens distorts beyond what the model covers (division coefficient {best.lam:+.2f} at the "
                       f"end of the searched {LAMBDA_RANGE[0]:+.1f}..{LAMBDA_RANGE[1]:+.1f}): a fisheye or a strong "
                       "wide-angle lens", len(turning), max_rotation_deg)
    if best.focals_px[best.best] in (grid[0], grid[-1]):
        return refused(f"the motion fits best at the edge of the searched {low * frame_px:.0f}-{high * frame_px:.0f} "
                       "px: no focal length explains it", len(turning), max_rotation_deg)
    fine = [_fine(s, turning, lens(s.lam), cost_scale_px) for s in _band(coarse)]
    focal_px, lam = _minimum(fine, slice(None))
    samples = np.array([_minimum(fine, choice) for choice in block_bootstrap(turning, BOOTSTRAP_SAMPLES)])
    spread = robust_spread(np.log(samples[:, 0]))
    lam_spread = None if given else robust_spread(samples[:, 1])
    estimated_lam = lam
    if not given and abs(lam) <= max(2 * lam_spread, LAMBDA_NEGLIGIBLE) and any(s.lam == 0.0 for s in fine):
        lam = 0.0  # no distortion told apart from none: the focal length without it (as the camera runs)
        focal_px = _best_focal(next(s for s in fine if s.lam == 0.0))
    if spread > MAX_RELATIVE_UNCERTAINTY:
        lens_part = "" if given else (f", the lens's division coefficient {lam:+.2f} +- {lam_spread:.2f}: the turns do "
                                      "not tell the focal length from the lens's distortion")
        return refused(f"the motion fits a wide range of focal lengths (+-{100 * spread:.0f} % at 1 sigma, best "
                       f"{focal_px * frame_px:.0f} px{lens_part})", len(turning), max_rotation_deg, spread)
    nearest = min(fine, key=lambda s: abs(s.lam - lam))
    start = nearest.motions[int(np.argmin(np.abs(np.log(nearest.focals_px / focal_px))))]
    parts = {"bootstrap": spread,
             "principal_point": _principal_point_part(turning, (lambda c: GivenLens(c, distortion)) if given else
                                                      (lambda c: DivisionLens(c, radius_px, lam)),
                                                      centre, focal_px, start, cost_scale_px, w),
             "lens_model": 0.0 if given else abs(_focal_per_lambda(fine, lam)) * max(
                 LENS_MODEL_SHARE * abs(lam), abs(estimated_lam - lam))}  # a lens taken as none may be one
    uncertainty = float(np.sqrt(sum(v**2 for v in parts.values())))
    if uncertainty > MAX_RELATIVE_UNCERTAINTY:
        largest = max(parts, key=parts.get)
        return refused(f"the focal length is not pinned down: +-{100 * uncertainty:.0f} % at 1 sigma (best "
                       f"{focal_px * frame_px:.0f} px), +-{100 * parts[largest]:.0f} % of it from "
                       f"{UNCERTAINTY_SOURCES[largest]}", len(turning), max_rotation_deg, spread)
    return FocalEstimate(focal_px * frame_px, uncertainty, len(turning), True, "", max_rotation_deg, spread,
                         None if given else lam, lam_spread, not given, radius_px * frame_px, still_share, parts)


def _principal_point_part(pairs: Sequence[PointPair], lens_at, centre: tuple[float, float], focal_px: float,
                          motions: Motions, cost_scale_px: float, width_px: int) -> float:
    """The relative uncertainty of the focal length from the principal point's: how far the best focal length
    moves when the centre moves by ``PRINCIPAL_POINT_SIGMA_WIDTHS`` (1 sigma) either way along x and along y
    (half the difference per axis, the two axes combined; the lens, ``lens_at(centre)``, otherwise held)."""
    step_px = PRINCIPAL_POINT_SIGMA_WIDTHS * width_px
    focals = focal_px * np.exp(np.linspace(-0.1, 0.1, 9))  # 2.5 % apart
    halves = []
    for axis in (np.array([step_px, 0.0]), np.array([0.0, step_px])):
        moved = []
        for sign in (-1, 1):
            fit = PairFit(pairs, lens_at(tuple(np.asarray(centre) + sign * axis)), cost_scale_px)
            costs, _ = fit.profile(focals, focal_px, motions, "how much the principal point matters")
            moved.append(_parabola(np.log(focals), costs.sum(axis=1))[0])
        halves.append((moved[1] - moved[0]) / 2)
    return float(np.hypot(*halves))


def _focal_per_lambda(slices: list[_Slice], lam: float) -> float:
    """How fast the best log focal length changes with the lens coefficient near ``lam`` (per unit of it)."""
    if len(slices) < 2:
        return 0.0
    nearest = sorted(slices, key=lambda s: abs(s.lam - lam))[:3]
    return float(np.polyfit([s.lam for s in nearest], [math.log(_best_focal(s)) for s in nearest], 1)[0])


def _best_focal(lens_slice: _Slice) -> float:
    """The focal length of the slice's lowest cost (all pairs; a parabola in log f)."""
    return math.exp(_parabola(np.log(lens_slice.focals_px), lens_slice.costs.sum(axis=1))[0])


def _turning_pairs(pairs: Sequence[PointPair], lens: Lens, nominal_px: float, scale: float
                   ) -> tuple[list[PointPair], Motions, float]:
    """The pairs that turn by ``MIN_PAIR_ROTATION_DEG`` or more at the nominal focal length (through
    ``lens``), reduced to the inliers of their fundamental matrix, with their motions there; and the largest
    rotation of any pair, degrees."""
    K = np.array([[nominal_px, 0.0, lens.centre[0]], [0.0, nominal_px, lens.centre[1]], [0.0, 0.0, 1.0]])
    turning, rotations, translations, max_rotation_deg = [], [], [], 0.0
    for pair in pairs:
        first = lens.undistort_px(pair.first_px, nominal_px).astype(np.float32)
        second = lens.undistort_px(pair.second_px, nominal_px).astype(np.float32)
        cv2.setRNGSeed(0)  # deterministic sampling
        F, mask = cv2.findFundamentalMat(first, second, cv2.USAC_MAGSAC, FUNDAMENTAL_THRESHOLD_PX * scale, 0.999)
        if F is None or mask is None:
            continue
        inliers = mask[:, 0] > 0
        motion = essential_motion(first[inliers], second[inliers], K, ESSENTIAL_THRESHOLD_PX * scale)
        if motion is None:
            continue
        rotation_deg = float(np.degrees(Rotation.from_matrix(motion.R).magnitude()))
        max_rotation_deg = max(max_rotation_deg, rotation_deg)
        if rotation_deg >= MIN_PAIR_ROTATION_DEG:
            turning.append(PointPair(pair.first, pair.second, pair.first_px[inliers], pair.second_px[inliers]))
            rotations.append(motion.R)
            translations.append(motion.t_dir)
    return turning, (np.array(rotations), np.array(translations)), max_rotation_deg


def _lens_walk(pairs: Sequence[PointPair], lens, grid: np.ndarray, nominal_px: float, motions: Motions,
               cost_scale_px: float, estimate_lens: bool) -> list[_Slice]:
    """Coarse slices, ascending in ``lam``: the whole ``grid`` at ``lam = 0``, then ``lam`` stepped both ways
    (when ``estimate_lens``), each slice a walk over the grid from the previous one's best focal length, until
    the cost has risen out of the band or the range ends."""
    fit = PairFit(pairs, lens(0.0), cost_scale_px)
    costs, fitted = fit.profile(grid, nominal_px, motions)
    slices = {0: _Slice(0.0, grid, costs, fitted)}
    if not estimate_lens:
        return [slices[0]]
    for direction in (-1, 1):
        previous, k = slices[0], direction
        while LAMBDA_RANGE[0] - 1e-9 <= k * LAMBDA_STEP <= LAMBDA_RANGE[1] + 1e-9:
            lam = k * LAMBDA_STEP
            current = _focal_walk(PairFit(pairs, lens(lam), cost_scale_px), lam, grid, previous)
            slices[k] = current
            lowest = min(s.best_cost for s in slices.values())
            if current.best_cost > previous.best_cost and current.best_cost > lowest * (1 + LAMBDA_BAND):
                break
            previous, k = current, k + direction
    return [slices[k] for k in sorted(slices)]


def _focal_walk(fit: PairFit, lam: float, grid: np.ndarray, previous: _Slice) -> _Slice:
    """The costs at the grid's focal lengths next to ``previous``'s best (starting from its motions there),
    extended one focal length at a time while the lowest is at an end."""
    start = int(np.searchsorted(grid, previous.focals_px[previous.best] * (1 - 1e-9)))
    low, high = max(start - 1, 0), min(start + 1, len(grid) - 1)
    costs, fitted = fit.profile(grid[low : high + 1], grid[start], previous.motions[previous.best])
    found = {low + i: (c, m) for i, (c, m) in enumerate(zip(costs, fitted, strict=True))}
    while True:
        totals = {i: c.sum() for i, (c, _) in found.items()}
        best = min(totals, key=totals.get)
        if best == low and low > 0:
            low, new, neighbour = low - 1, low - 1, low
        elif best == high and high < len(grid) - 1:
            high, new, neighbour = high + 1, high + 1, high
        else:
            break
        motions, cost = fit.fit(grid[new], rescaled(found[neighbour][1], grid[neighbour] / grid[new]))
        found[new] = (cost, motions)
    order = sorted(found)
    return _Slice(lam, grid[order], np.array([found[i][0] for i in order]), [found[i][1] for i in order])


def _band(coarse: list[_Slice]) -> list[_Slice]:
    """The coarse slices whose best cost lies within ``LAMBDA_BAND`` of the lowest, with one neighbour on
    each side (a contiguous run)."""
    costs = np.array([s.best_cost for s in coarse])
    inside = np.flatnonzero(costs <= costs.min() * (1 + LAMBDA_BAND))
    return coarse[max(inside[0] - 1, 0) : inside[-1] + 2]


def _fine(coarse: _Slice, pairs: Sequence[PointPair], lens: Lens, cost_scale_px: float) -> _Slice:
    """The slice with a fine grid (``FINE_STEPS`` over +-``FINE_SPAN``) around its best focal length, and its
    coarse focal lengths outside that span."""
    centre_px = coarse.focals_px[coarse.best]
    focals = centre_px * np.exp(np.linspace(-FINE_SPAN, FINE_SPAN, FINE_STEPS))
    costs, fitted = PairFit(pairs, lens, cost_scale_px).profile(focals, centre_px, coarse.motions[coarse.best])
    outside = np.abs(np.log(coarse.focals_px / centre_px)) > FINE_SPAN
    all_focals = np.concatenate([coarse.focals_px[outside], focals])
    order = np.argsort(all_focals)
    all_costs = np.concatenate([coarse.costs[outside], costs])[order]
    all_motions = [m for m, keep in zip(coarse.motions, outside, strict=True) if keep] + fitted
    return _Slice(coarse.lam, all_focals[order], all_costs, [all_motions[i] for i in order])


def _minimum(slices: list[_Slice], choice) -> tuple[float, float]:
    """The focal length and lens coefficient of the lowest cost of the pairs ``choice`` (indices, or a slice):
    the minimum of a parabola in log f per lens slice, then of a parabola over ``lam`` through the lowest
    slice and its neighbours (log f interpolated along with it)."""
    log_f, lowest = np.zeros(len(slices)), np.zeros(len(slices))
    for i, s in enumerate(slices):
        log_f[i], lowest[i] = _parabola(np.log(s.focals_px), s.costs[:, choice].sum(axis=1))
    lams = np.array([s.lam for s in slices])
    j = int(np.argmin(lowest))
    if len(slices) < 3 or j in (0, len(slices) - 1):
        return float(np.exp(log_f[j])), float(lams[j])
    near = slice(j - 1, j + 2)
    lam, _ = _parabola(lams[near], lowest[near])
    return float(np.exp(np.polyval(np.polyfit(lams[near], log_f[near], 2), lam))), lam


def _parabola(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Where the parabola through the lowest sample of ``y`` and its two neighbours is lowest (within them),
    and its value there; the lowest sample itself at an end. Only the nearest samples: the profile in log f
    is lopsided (a focal length too short puts far points beyond infinity, which costs more than one too
    long), and a wider fit would follow the lopsidedness (+1 % on exact correspondences)."""
    i = int(np.argmin(y))
    if i in (0, len(x) - 1):
        return float(x[i]), float(y[i])
    u = x[i - 1 : i + 2] - x[i]
    a, b, c = np.polyfit(u, y[i - 1 : i + 2], 2)
    if a <= 0:
        return float(x[i]), float(y[i])
    at = float(np.clip(-b / (2 * a), u[0], u[2]))
    return float(x[i] + at), float(np.polyval((a, b, c), at))
