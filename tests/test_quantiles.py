import numpy as np

from flowvo.odometry.quantiles import median, percentile


def test_median_is_numpys_exactly():
    rng = np.random.default_rng(0)
    for count in (1, 2, 3, 4, 9, 10, 601, 1054):
        for dtype in (np.float64, np.float32, np.int64):
            values = (rng.normal(size=count) * 100).astype(dtype)
            assert median(values) == float(np.median(values))
    assert median(np.array([3.0, 1.0, 3.0, 1.0])) == 2.0
    assert median(np.array([0.1, 0.7])) == (0.1 + 0.7) / 2


def test_median_of_values_with_a_nan_is_nan_as_numpys():
    for values in (np.array([1.0, np.nan, 2.0]), np.array([np.nan, 5.0, 1.0, 2.0])):
        assert np.isnan(median(values)) and np.isnan(np.median(values))


def test_percentile_is_numpys_exactly_in_either_precision():
    rng = np.random.default_rng(1)
    for count in (1, 2, 3, 10, 601, 1054):
        for dtype in (np.float64, np.float32):
            for q in (0, 10, 50, 90, 99.5, 100):
                values = (rng.normal(size=count) * 30).astype(dtype)
                assert percentile(values, q) == float(np.percentile(values, q))
    assert percentile(np.array([0.0, 10.0]), 90) == 9.0
    assert np.isnan(percentile(np.array([1.0, np.nan, 3.0]), 90))
