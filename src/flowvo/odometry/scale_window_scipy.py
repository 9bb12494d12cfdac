"""The scale window's robust fit by SciPy's ``least_squares``: the well-kept solver the window's own iterations
(:func:`flowvo.odometry.scale_window.robust_log_lengths`) are measured against
(``ScaleWindow(solver=scipy_log_lengths)``).
Log lengths of steps in metres' logs; sigmas of logs."""

from __future__ import annotations

import numpy as np

from flowvo.odometry.scale_window import HUBER_THRESHOLD, UNDETERMINED_WEIGHT, measurement_columns


def scipy_log_lengths(links: list[tuple[int, float, float]], absolutes: list[tuple[int, float, float]],
                      count: int, threshold: float = HUBER_THRESHOLD,
                      sums: list[tuple[int, int, float, float]] = ()) -> np.ndarray:
    """The same robust fit as :func:`robust_log_lengths` (same measurements, Huber then Cauchy of scale
    ``threshold`` sigmas) by SciPy's ``least_squares`` (trust-region reflective, analytic Jacobian): the
    well-kept solver the window's own iterations are measured against (``ScaleWindow(solver=scipy_log_lengths)``)."""
    from scipy.optimize import least_squares

    link_k, link_value, link_sigma = measurement_columns(links)
    absolute_k, absolute_value, absolute_sigma = measurement_columns(absolutes)
    spans = [np.arange(first, last + 1) for first, last, _, _ in sums]
    rows = len(link_k) + len(absolute_k) + len(spans) + count
    jacobian = np.zeros((rows, count))
    jacobian[np.arange(len(link_k)), link_k] = 1.0 / link_sigma
    jacobian[np.arange(len(link_k)), link_k - 1] = -1.0 / link_sigma
    jacobian[len(link_k) + np.arange(len(absolute_k)), absolute_k] = 1.0 / absolute_sigma
    jacobian[rows - count:] = np.sqrt(UNDETERMINED_WEIGHT) * np.eye(count)
    first_sum = len(link_k) + len(absolute_k)

    def residuals(x: np.ndarray) -> np.ndarray:
        summed = [(np.log(np.exp(x[span]).sum()) - value) / sigma
                  for span, (_, _, value, sigma) in zip(spans, sums, strict=True)]
        return np.concatenate([(x[link_k] - x[link_k - 1] - link_value) / link_sigma,
                               (x[absolute_k] - absolute_value) / absolute_sigma, summed,
                               np.sqrt(UNDETERMINED_WEIGHT) * x])

    def derivatives(x: np.ndarray) -> np.ndarray:
        for row, (span, (_, _, _, sigma)) in enumerate(zip(spans, sums, strict=True)):
            lengths = np.exp(x[span])
            jacobian[first_sum + row, span] = lengths / lengths.sum() / sigma
        return jacobian

    x = np.zeros(count)
    for loss in ("huber", "cauchy"):
        x = least_squares(residuals, x, derivatives, loss=loss, f_scale=threshold).x
    return x
