"""Small numerics of the per-frame step with NumPy's results, without the cost of NumPy's general wrappers.

Inside the stream ``np.median`` cost 25-70 us a call, ``np.percentile`` 100-140 us and ``np.linalg.solve`` of a
5x5 system 8 us, where a frame takes a dozen medians and fifteen such solves: the stream runs two threads under one
GIL, so such Python costs it wall-clock time. The order statistics and the interpolation arithmetic are NumPy's
own, so those results are identical (tested); the solve is LAPACK's gesv, as NumPy's, through SciPy's build of it.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dgesv


def median(values: np.ndarray) -> float:
    """The median of ``values`` (N,): the middle value, or the mean of the two middle ones; NaN where a value is NaN
    or there is none (as ``np.median``, without its warning)."""
    if not len(values):
        return float("nan")
    middle = len(values) // 2
    odd = len(values) % 2 == 1
    part = np.partition(values, (middle, -1) if odd else (middle - 1, middle, -1))
    if np.isnan(part[-1]):
        return float("nan")
    return float(part[middle] if odd else (part[middle - 1] + part[middle]) / 2)


def percentile(values: np.ndarray, q: float) -> float:
    """The ``q``-th percentile (0..100) of floating-point ``values`` (N,), interpolated linearly between the
    two order statistics around position ``(N - 1) q / 100`` (the fraction as a Python float, so that float32 values
    are interpolated in float32); NaN where a value is NaN. Like ``np.percentile``, refuses an empty array."""
    if not len(values):
        raise IndexError("the percentile of no values")
    last = len(values) - 1
    position = last * np.float64(q / 100)
    lower = min(int(np.floor(position)), last)
    upper = min(lower + 1, last)
    part = np.partition(values, (lower, upper, -1))
    if np.isnan(part[-1]):
        return float("nan")
    below, above = part[lower], part[upper]
    if position >= last:
        return float(above)
    gap, share = above - below, float(position - lower)
    return float(above - gap * (1 - share) if share >= 0.5 else below + gap * share)


def row_norms(vectors: np.ndarray) -> np.ndarray:
    """The length of each row of ``vectors`` (N, D): ``np.linalg.norm(vectors, axis=1)``, the same sum of squares
    and root."""
    return np.sqrt((vectors * vectors).sum(axis=1))


def solved(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.linalg.solve(A, b)`` of a small square system: the same LAPACK routine (gesv), called directly. SciPy's
    and NumPy's builds gave identical solutions of 5x5 systems here, and differed in the last bits from 6x6 up."""
    _, _, x, info = dgesv(A, b)
    if info:
        raise np.linalg.LinAlgError("Singular matrix")
    return x
