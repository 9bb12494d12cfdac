import numpy as np
import pytest

from flowvo.odometry.numeric import median, percentile, row_norms, solved


def test_median_is_numpys_exactly():
    rng = np.random.default_rng(0)
    for count in (1, 2, 3, 4, 9, 10, 601, 1054):
        for dtype in (np.float64, np.float32, np.int64):
            values = (rng.normal(size=count) * 100).astype(dtype)
            assert median(values) == float(np.median(values))
    assert median(np.array([3.0, 1.0, 3.0, 1.0])) == 2.0
    assert median(np.array([0.1, 0.7])) == (0.1 + 0.7) / 2


def test_median_of_values_with_a_nan_or_of_none_is_nan_as_numpys():
    for values in (np.array([1.0, np.nan, 2.0]), np.array([np.nan, 5.0, 1.0, 2.0])):
        assert np.isnan(median(values)) and np.isnan(np.median(values))
    assert np.isnan(median(np.zeros(0)))


def test_percentile_is_numpys_exactly_in_either_precision():
    rng = np.random.default_rng(1)
    for count in (1, 2, 3, 10, 601, 1054):
        for dtype in (np.float64, np.float32):
            for q in (0, 10, 50, 90, 99.5, 100):
                values = (rng.normal(size=count) * 30).astype(dtype)
                assert percentile(values, q) == float(np.percentile(values, q))
    assert percentile(np.array([0.0, 10.0]), 90) == 9.0
    assert np.isnan(percentile(np.array([1.0, np.nan, 3.0]), 90))
    with pytest.raises(IndexError):
        percentile(np.zeros(0), 50)


def test_solved_is_numpys_solve_and_refuses_a_singular_system():
    rng = np.random.default_rng(2)
    for size in (2, 5, 20):
        for _ in range(50):
            A, b = rng.normal(size=(size, size)), rng.normal(size=size)
            A = A @ A.T + 0.1 * np.eye(size)
            np.testing.assert_allclose(solved(A, b), np.linalg.solve(A, b), rtol=1e-10, atol=1e-12)
    with pytest.raises(np.linalg.LinAlgError):
        solved(np.ones((3, 3)), np.ones(3))


def test_row_norms_are_numpys_exactly():
    rng = np.random.default_rng(4)
    for dtype in (np.float64, np.float32):
        vectors = rng.normal(size=(300, 2)).astype(dtype)
        np.testing.assert_array_equal(row_norms(vectors), np.linalg.norm(vectors, axis=1))
    np.testing.assert_array_equal(row_norms(np.array([[3.0, 4.0, 12.0]])), [13.0])
