"""The window stage of the default method: every step's metric length refined jointly over a sliding
window of steps, from the measurements of all of them.

Per step the default method measures, when it can: its length from the road plane and the camera height
(absolute, a few % noise, heavy tails), the ratio of its length to the previous step's from points seen in three
frames (relative, about 1 % noise, weighted by its own standard error and its steps' turn: a ratio whose points
disagree counts less, and so does one through a turn; :mod:`flowvo.odometry.scale_propagation`), and where no road has
been seen for a while the network's distance (absolute, biased on real frames). With ``x_k`` the log of step k's
length, the measurements are ``x_k = log(road)`` and ``x_k - x_(k-1) = log(ratio)``; a road measured from a key
frame several steps back (at low speed) measures the log of their summed length. The window solves these by
robust least squares (Huber, then Cauchy), so the road's scale is averaged over the window's many frames and
carried through stretches without road, while a wrong road or ratio is down-weighted.

Each step's length is final ``latency_frames`` steps after it arrives: it then has measurements on both
sides. Until something measures the scale (a drive that starts fast, before its first trusted road), the steps
are held up to ``MAX_UNMEASURED_HOLD_S``, so that the first measurement reaches them through their ratios.
A step that leaves the window is marginalised, not forgotten: what its road, network and prior said of its
length, carried through its link to the next step, becomes a prior on that step (the
forward message of the chain, with the robust weights of the last solve). So a road measured before a long
stretch without one still sets the scale, less surely with every link; the per-pair estimate's held speed
keeps only a weak hold. A standstill ends the window and its prior (the next motion starts a new one); a time gap
longer than ``SPEED_HORIZON_S`` without a ratio breaks the link between the steps around it.

Every final step is also recorded (:class:`StepRecord`): its length, the standard deviation of its log from
the window's solve, and what measured it, for a user who weighs the poses (a fusion filter) or wants to
know which stretches rest on the road.

Pure computation over NumPy arrays. Motions ``T_prev_cur`` (4x4, metres) as the stream chains them.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import cached_property
from typing import NamedTuple

import numpy as np

from flowvo.geometry import invert_se3, rotation_angle_between_rad
from flowvo.odometry.numeric import median
from flowvo.odometry.speed_prior import SPEED_HORIZON_S
from flowvo.odometry.two_view import se3_next_prev

WINDOW_S = 2.0  # the steps solved together: 20 at 10 frames/s (real clips: 15-60 steps measured alike)
MIN_WINDOW_STEPS = 10
LATENCY_FRAMES = 5  # real clips, t_err at latency 0 / 3 / 5: 01 1.24 / 1.26 / 1.26, 06 1.35 / 1.45 / 1.45,
# 07 2.27 / 1.99 / 1.87 %: a step starting from rest is only measured well once the car moves
MAX_LATENCY_FRAMES = 100  # the window holds its pending steps: longer latencies are no odometry any more
RATIO_SIGMA = 0.008  # log: the three-view ratio's error beyond its own standard error, which adds to it (real
# clips: steps whose ratio's standard error is below 0.5 % are 0.55-0.8 % off, rms)
RATIO_SIGMA_PER_DEG = 0.004  # log per degree that the ratio's steps turn (the larger of the two), added too: the
# ratios' error grows with the turn, alike at 10 and 5 frames/s (real clips, rms: 0.6 % below 1 degree a step, 1.4 %
# at 2-3, 2.0 % at 3-5, 3.0 % beyond; +0.8 % on average at 3-5 degrees, +0.9 % with the true motions on 01 and 07)
ROAD_SIGMA = 0.05  # log: the road length's spread at constant speed (real clip 06)
NETWORK_SIGMA = 0.4  # log: the network's distance, biased on real frames (+45 % through a turn of clip 07)
PAIR_SIGMA = 2.0  # log: the per-pair estimate, so that a window without any measurement stays solvable and a long
# stretch without road keeps a weak hold on the speed last measured (the speed prior's); it is not carried into
# the prior of a step that leaves the window (it repeats the roads and network distances it came from)
UNLINKED_SIGMA = 0.05  # log: consecutive steps without a ratio change their speed this little (10 Hz)
HUBER_THRESHOLD = 2.0  # sigmas: beyond, Huber counts residuals linearly; Cauchy's scale (real clips, t_err
# 01 / 06 / 07: Huber alone 1.37 / 1.38 / 1.92 %, then Cauchy 1.50 / 1.19 / 1.84 %)
HUBER_ITERATIONS = 3  # Huber only brings Cauchy near its minimum
MAX_CAUCHY_ITERATIONS = 50
UNDETERMINED_WEIGHT = 1e-9  # 1/log^2: holds a step no measurement reaches at 0 (not used: it keeps its pair length)
UNSCALED_LOG_SIGMA = 0.5  # log: a moving step known less surely than this has only the held speed behind it
# (the network's distance alone: 0.4)
MAX_UNMEASURED_HOLD_S = 3.0  # a window that no road, network or carried prior has measured yet (a drive that starts
# fast, before its first trusted road; a camera whose mounting the drive's planes put in doubt) holds its steps this
# long for one, so that they get lengths through their ratios instead of the held speed (none yet: 0 m)
CONVERGED_LOG = 1e-4  # Cauchy stops once no log length moves more (0.01 % of a step: far below any noise;
# 1e-6 took 40 % more iterations for the same clip results to four digits)


@dataclass(frozen=True)
class StepScale:
    """One step as the window needs it: its rotation ``R`` (``R_next_prev``) and unit translation
    direction ``t_dir`` (next frame), the per-pair estimate of its length ``pair_m``, and what measured its
    length: ``road_m``, ``network_m`` (metres) and ``ratio`` (to the previous step's length, with the
    standard error ``ratio_log_sigma`` of its log), each None where nothing did; ``dt_s`` the time since the
    previous frame. ``road_m`` is the road's length of the last ``road_steps`` steps, this one the last: a
    road measured from a key frame several steps back (at low speed) measures their sum. ``mounting_pending``: the
    road planes so far put the camera's mounting in doubt (``RoadPlaneTally.mounting_pending``); ``mounting_taken``:
    this step took the camera's mounting from the drive, so the roads measured before it went through the wrong
    one."""

    R: np.ndarray
    t_dir: np.ndarray
    pair_m: float
    dt_s: float
    road_m: float | None = None
    network_m: float | None = None
    ratio: float | None = None
    ratio_log_sigma: float = 0.0
    road_steps: int = 1
    mounting_pending: bool = False
    mounting_taken: bool = False

    @cached_property
    def turn_deg(self) -> float:
        """How far the step turns: the angle of its rotation, degrees (computed once, read by every solve)."""
        return float(np.degrees(rotation_angle_between_rad(self.R, np.eye(3))))


class _WindowProblem:
    """The window's measurements as arrays (see :func:`robust_log_lengths` for their meaning): the weighted
    normal equations at any robust weights, and each measurement's residual in sigmas."""

    def __init__(self, links: list[tuple[int, float, float]], absolutes: list[tuple[int, float, float]], count: int,
                 sums: list[tuple[int, int, float, float]]) -> None:
        self.count = count
        self.link_k, self.link_value, self.link_sigma = measurement_columns(links)
        self.absolute_k, self.absolute_value, self.absolute_sigma = measurement_columns(absolutes)
        steps = np.arange(count)
        self.spans = np.array([(steps >= first) & (steps <= last) for first, last, _, _ in sums]).reshape(len(sums),
                                                                                                         count)
        self.sum_value, self.sum_sigma = (np.array([row[i] for row in sums], np.float64) for i in (2, 3))
        # where each link's and absolute's weight lands in the flattened normal matrix (one bincount builds it)
        link_k, absolute_k = self.link_k, self.absolute_k
        self._cells = np.concatenate([link_k * (count + 1), (link_k - 1) * (count + 1), link_k * count + link_k - 1,
                                      (link_k - 1) * count + link_k, absolute_k * (count + 1)])

    def summed(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each sum's log at ``x``, and its derivatives (each step's share of the sum)."""
        lengths = np.where(self.spans, np.exp(x), 0.0)
        total = lengths.sum(axis=1)
        return np.log(total), lengths / total[:, None]

    def normal_equations(self, weights: tuple[np.ndarray, np.ndarray, np.ndarray], at: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
        """The normal matrix (count, count) and right-hand side of the least squares with the robust
        ``weights`` (links, absolutes, sums), the sums linearised at ``at`` (Gauss-Newton)."""
        count, link_k, absolute_k = self.count, self.link_k, self.absolute_k
        w_link, w_absolute = weights[0] / self.link_sigma**2, weights[1] / self.absolute_sigma**2
        # float: without any measurement bincount's zeros are integers
        normal = np.bincount(self._cells, np.concatenate([w_link, w_link, -w_link, -w_link, w_absolute]),
                             count * count).astype(np.float64, copy=False).reshape(count, count)
        normal.flat[:: count + 1] += UNDETERMINED_WEIGHT
        rhs = (np.bincount(link_k, w_link * self.link_value, count)
               - np.bincount(link_k - 1, w_link * self.link_value, count)
               + np.bincount(absolute_k, w_absolute * self.absolute_value, count))
        if len(self.sum_value):
            log_sum, shares = self.summed(at)
            w_sum = weights[2] / self.sum_sigma**2
            normal += shares.T @ (w_sum[:, None] * shares)
            rhs += shares.T @ (w_sum * (self.sum_value - log_sum + shares @ at))
        return normal, rhs

    def normalised(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each measurement's residual at ``x`` in its own sigmas (links, absolutes, sums)."""
        return (np.abs(x[self.link_k] - x[self.link_k - 1] - self.link_value) / self.link_sigma,
                np.abs(x[self.absolute_k] - self.absolute_value) / self.absolute_sigma,
                np.abs(self.summed(x)[0] - self.sum_value) / self.sum_sigma if len(self.sum_value) else np.zeros(0))


class StepRecord(NamedTuple):
    """What became of one step: ``time_s`` (its end frame), its final ``length_m``, the standard deviation of
    the natural log of that length (``log_sigma``: 0.01 is 1 %; above 1 where only the per-pair estimate's
    held speed measured it, None at a standstill or where nothing did), and ``measured_by``: what measured
    the step itself, "+"-joined from "road", "ratio" and "network" ("none": only its neighbours or the held
    speed; "standstill")."""

    time_s: float
    length_m: float
    log_sigma: float | None
    measured_by: str

    @property
    def unscaled(self) -> bool:
        """A moving step whose length rests on no measurement of the scale (road, ratio to a measured step,
        network): only the held speed, or nothing."""
        return self.measured_by != "standstill" and (self.log_sigma is None or self.log_sigma > UNSCALED_LOG_SIGMA)


def robust_log_lengths(links: list[tuple[int, float, float]], absolutes: list[tuple[int, float, float]],
                       count: int, threshold: float = HUBER_THRESHOLD, iterations: int = HUBER_ITERATIONS,
                       sums: list[tuple[int, int, float, float]] = ()) -> np.ndarray:
    """The log lengths ``x`` (count,) of the measurements under a robust loss, by iteratively reweighted
    least squares: Huber first, convex, from the plain least-squares start; then Cauchy from there, which
    lets gross outliers go. Each iteration solves the weighted normal equations exactly (LAPACK); a sum,
    not linear in ``x``, is linearised where the last iteration ended (Gauss-Newton), from equal lengths.

    ``links``: (k, log ratio, sigma) for ``x_k - x_(k-1)``; ``absolutes``: (k, log length, sigma) for ``x_k``;
    ``sums``: (first, last, log length, sigma) for the log of the summed lengths of steps first..last (a
    road measured from a key frame several steps back). A connected run of steps without an absolute
    measurement or sum is left near 0 (undetermined).
    """
    return _robust_solution(_WindowProblem(links, absolutes, count, sums), threshold, iterations)


def _robust_solution(problem: _WindowProblem, threshold: float = HUBER_THRESHOLD,
                     iterations: int = HUBER_ITERATIONS) -> np.ndarray:
    """:func:`robust_log_lengths` of a window's measurements already gathered as arrays."""
    def solve(weights: tuple[np.ndarray, np.ndarray, np.ndarray], at: np.ndarray) -> np.ndarray:
        return np.linalg.solve(*problem.normal_equations(weights, at))

    x = solve((np.ones(len(problem.link_k)), np.ones(len(problem.absolute_k)), np.ones(len(problem.sum_value))),
              np.zeros(problem.count))
    for _ in range(iterations):
        x = solve(tuple(np.minimum(1.0, threshold / np.maximum(r, 1e-12)) for r in problem.normalised(x)), x)
    for _ in range(MAX_CAUCHY_ITERATIONS):
        previous, x = x, solve(tuple(cauchy_weight(r, threshold) for r in problem.normalised(x)), x)
        if np.abs(x - previous).max() < CONVERGED_LOG:
            break
    return x


def log_length_sigmas(links: list[tuple[int, float, float]], absolutes: list[tuple[int, float, float]],
                      count: int, x: np.ndarray, threshold: float = HUBER_THRESHOLD,
                      sums: list[tuple[int, int, float, float]] = ()) -> np.ndarray:
    """The standard deviation (count,) of each solved log length ``x`` (a robust solve's result): the
    diagonal of the inverse normal matrix, each measurement under the Cauchy weight it keeps at ``x``
    (Laplace's approximation; a step no measurement reaches gets a huge sigma)."""
    return _sigmas(_WindowProblem(links, absolutes, count, sums), x, threshold)


def _sigmas(problem: _WindowProblem, x: np.ndarray, threshold: float = HUBER_THRESHOLD) -> np.ndarray:
    """:func:`log_length_sigmas` of a window's measurements already gathered as arrays."""
    normal, _ = problem.normal_equations(tuple(cauchy_weight(r, threshold) for r in problem.normalised(x)), x)
    return np.sqrt(np.diag(np.linalg.inv(normal)))


def cauchy_weight(normalised_residual: np.ndarray | float, threshold: float = HUBER_THRESHOLD) -> np.ndarray:
    """The weight a residual of ``normalised_residual`` sigmas keeps under the Cauchy loss of scale
    ``threshold`` sigmas (1 at zero, 1/2 at the threshold)."""
    return 1.0 / (1.0 + (np.asarray(normalised_residual) / threshold) ** 2)


def carried_prior(measured: list[tuple[float, float]], link: tuple[float, float] | None
                  ) -> tuple[float, float] | None:
    """The prior (log length, sigma) on the next step when a step leaves the window: what ``measured`` its
    log length ((value, sigma) each: its prior, road, network; robust weights folded into the sigmas), fused,
    then carried through ``link`` (log ratio to the next step, sigma). None without any measurement or without
    a link: nothing is known of the next step."""
    if not measured or link is None:
        return None
    information = sum(1.0 / sigma**2 for _, sigma in measured)
    mean = sum(value / sigma**2 for value, sigma in measured) / information
    return mean + link[0], float(np.sqrt(1.0 / information + link[1] ** 2))


def measurement_columns(measurements: list[tuple[int, float, float]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(k, value, sigma) rows as three arrays: steps (int), values, sigmas."""
    if not measurements:
        return np.zeros(0, np.int64), np.zeros(0), np.ones(0)
    k, value, sigma = (np.array(column) for column in zip(*measurements, strict=True))
    return k.astype(np.int64), value.astype(np.float64), sigma.astype(np.float64)


class ScaleWindow:
    """The sliding window (see the module docstring): ``push`` a step, get back the motions that are
    final; ``flush`` at the end of the drive."""

    def __init__(self, latency_frames: int = LATENCY_FRAMES, window_s: float = WINDOW_S, ratios: bool = True,
                 marginalise: bool = True, solver: Callable[..., np.ndarray] | None = None) -> None:
        self.latency_frames = latency_frames
        self.window_s = window_s
        self.ratios = ratios  # False: the road lengths alone, averaged (for the ablation)
        self.marginalise = marginalise  # False: steps that leave the window are forgotten (for the ablation)
        self.solver = solver  # another solver of robust_log_lengths's measurements (the ablation's SciPy one,
        # flowvo.odometry.scale_window_scipy.scipy_log_lengths); None: the window's own
        self._steps: deque[tuple[float, StepScale]] = deque()  # the window: emitted steps, then pending ones
        self._pending = 0
        self._prior: tuple[float, float] | None = None  # (log length, sigma) of the window's first step, from the
        # steps that left it
        self._measured = False  # whether a road, network distance or prior has measured a step since the window began
        self.records: list[StepRecord] = []  # every final step so far, in order

    def push(self, time_s: float, step: StepScale | None) -> list[tuple[float, np.ndarray]]:
        """Add the step ending at ``time_s`` (None: a standstill, identity motion); the motions
        (time_s, ``T_prev_cur``) now final, in order."""
        if step is None:
            emitted = self.flush()
            self.records.append(StepRecord(time_s, 0.0, None, "standstill"))
            return emitted + [(time_s, np.eye(4))]
        self._steps.append((time_s, step))
        self._pending += 1
        self._measured = self._measured or self._prior is not None or _usable(step.road_m) or _usable(step.network_m)
        if step.mounting_taken:
            self._forget_roads()
        if step.mounting_pending or step.mounting_taken:  # held for a road measured through the drive's mounting
            self._measured = False
        if self._pending <= self.latency_frames:
            return []
        first_pending_s = self._steps[len(self._steps) - self._pending][0]
        if self.latency_frames and not self._measured and time_s - first_pending_s < MAX_UNMEASURED_HOLD_S:
            return []  # held until something measures the scale (see MAX_UNMEASURED_HOLD_S; latency 0: never held)
        return self._emit(self._pending - self.latency_frames)

    def _forget_roads(self) -> None:
        """The road lengths of the window's steps, and the prior carried from those that left it, were measured
        through a camera mounting the drive has just replaced (a camera rolled 6 degrees and not told: its first
        plane, trusted by chance, read its step 25 % long, and the window chained the next 15 steps from it at
        half their length): forgotten, so that the roads measured through the new one scale those steps."""
        self._steps = deque((time_s, step if step.road_m is None else replace(step, road_m=None))
                            for time_s, step in self._steps)
        self._prior = None

    def flush(self) -> list[tuple[float, np.ndarray]]:
        """Every pending motion, final now; the window starts anew."""
        emitted = self._emit(self._pending)
        self._steps.clear()
        self._prior = None
        self._measured = False
        return emitted

    def _emit(self, count: int) -> list[tuple[float, np.ndarray]]:
        if not count:
            return []
        links, absolutes, sums = self._measurements()
        problem = _WindowProblem(links, absolutes, len(self._steps), sums)  # one per solve, sigmas included
        log_lengths = _robust_solution(problem) if self.solver is None else \
            self.solver(links, absolutes, len(self._steps), sums=sums)
        measured = [k for k, _, _ in absolutes] + [last for _, last, _, _ in sums]
        anchored = self._anchored(links, measured)
        lengths = np.where(anchored, np.exp(log_lengths), [step.pair_m for _, step in self._steps])
        sigmas = _sigmas(problem, log_lengths)
        first = len(self._steps) - self._pending
        emitted = [(self._steps[k][0], invert_se3(se3_next_prev(self._steps[k][1].R,
                                                                self._steps[k][1].t_dir * lengths[k])))
                   for k in range(first, first + count)]
        self.records += [StepRecord(self._steps[k][0], float(lengths[k]), float(sigmas[k]) if anchored[k] else None,
                                    _measured_by(self._steps[k][1], self.ratios) if anchored[k] else "none")
                         for k in range(first, first + count)]
        self._pending -= count
        intervals = [step.dt_s for _, step in self._steps]
        keep = max(MIN_WINDOW_STEPS, int(round(self.window_s / median(intervals))))
        leaving = max(0, len(self._steps) - max(keep, self._pending))
        for k in range(leaving if self.marginalise else 0):
            self._prior = self._marginal(k, log_lengths, links)
        for _ in range(leaving):
            self._steps.popleft()
        return emitted

    def _measurements(self) -> tuple[list[tuple[int, float, float]], list[tuple[int, float, float]],
                                     list[tuple[int, int, float, float]]]:
        """The window's links (k, log ratio, sigma) of step k to step k - 1, its absolute measurements
        (k, log length, sigma): the prior of its first step, then each step's road, network and per-pair
        lengths, and its roads over several steps (first, last, log length, sigma; one whose first step
        has left the window is left out)."""
        links, absolutes, sums = [], [] if self._prior is None else [(0, *self._prior)], []
        for k, (_, step) in enumerate(self._steps):
            if k and self.ratios and _usable(step.ratio):
                turn_sigma = RATIO_SIGMA_PER_DEG * max(self._steps[k - 1][1].turn_deg, step.turn_deg)
                links.append((k, float(np.log(step.ratio)),
                              math.hypot(RATIO_SIGMA, turn_sigma, step.ratio_log_sigma)))
            elif k and step.dt_s <= SPEED_HORIZON_S:  # about the same speed: lengths in proportion to the time
                links.append((k, float(np.log(step.dt_s / self._steps[k - 1][1].dt_s)), UNLINKED_SIGMA))
            road = step.road_m if step.road_steps == 1 else None
            absolutes += [(k, float(np.log(value)), sigma) for value, sigma in
                          ((road, ROAD_SIGMA), (step.network_m, NETWORK_SIGMA), (step.pair_m, PAIR_SIGMA))
                          if _usable(value)]
            if step.road_steps > 1 and _usable(step.road_m) and k + 1 >= step.road_steps:
                sums.append((k + 1 - step.road_steps, k, float(np.log(step.road_m)), ROAD_SIGMA))
        return links, absolutes, sums

    def _anchored(self, links: list[tuple[int, float, float]], measured: list[int]) -> np.ndarray:
        """Which steps are linked to one of the ``measured`` steps (an absolute length or a sum ending there;
        the others keep their per-pair length)."""
        linked = {k for k, _, _ in links}
        segment = np.cumsum([k not in linked for k in range(len(self._steps))])  # runs of steps tied to one another
        anchored = np.zeros(segment.max(initial=0) + 1, bool)  # per run (a lookup: np.isin took 80 us here)
        anchored[segment[measured]] = True
        return anchored[segment]

    def _marginal(self, k: int, log_lengths: np.ndarray, links: list[tuple[int, float, float]]
                  ) -> tuple[float, float] | None:
        """The prior on step k + 1 once step k leaves the window (the steps before it have left, so the prior
        is its own): its prior, road (of this step alone) and network lengths, each under its Cauchy weight at
        the solved ``log_lengths``, carried through its link."""
        def robust(value: float, sigma: float, residual: float) -> tuple[float, float]:
            return value, sigma / float(np.sqrt(cauchy_weight(abs(residual) / sigma)))

        step = self._steps[k][1]
        lengths = ((step.road_m if step.road_steps == 1 else None, ROAD_SIGMA), (step.network_m, NETWORK_SIGMA))
        measured = [(float(np.log(value)), sigma) for value, sigma in lengths if _usable(value)]
        if self._prior is not None:
            measured.append(self._prior)
        link = next((robust(value, sigma, log_lengths[k + 1] - log_lengths[k] - value)
                     for j, value, sigma in links if j == k + 1), None)
        return carried_prior([robust(value, sigma, log_lengths[k] - value) for value, sigma in measured], link)


def _measured_by(step: StepScale, ratios: bool) -> str:
    """What measured ``step`` itself (see :class:`StepRecord`; its ratio only where the window uses ratios)."""
    kinds = [kind for kind, value in (("road", step.road_m), ("ratio", step.ratio if ratios else None),
                                      ("network", step.network_m)) if _usable(value)]
    return "+".join(kinds) or "none"


def _usable(value: float | None) -> bool:
    """A measured length or ratio the solve can take: given, positive and finite."""
    return value is not None and 0.0 < value < np.inf
