"""The road flow's error read from a trusted plane's points (flowvo.odometry.road_noise): exact known cases, a level
road triangulated from flow with a known error, and the baseline the drive's road then needs."""

import numpy as np
import pytest

from flowvo.odometry.road_noise import (
    BASELINE_SNR,
    MAD_TO_SIGMA,
    MIN_NOISE_POINTS,
    NOISE_PLANES,
    RoadFlowNoise,
    flow_error_px,
)
from flowvo.odometry.road_plane import fit_road_plane
from flowvo.odometry.road_profile import road_residuals
from flowvo.odometry.two_view import EssentialMotion, translation_parallax_px, triangulate


def test_the_error_is_the_robust_spread_of_residual_times_parallax_over_the_points_near_the_plane():
    residuals = np.array([0.1, -0.05, 0.02, -0.2] * 10 + [0.9, np.nan])  # the last two: off the road
    parallax_px = np.array([5.0, 10.0, 25.0, 2.5] * 10 + [10.0, 10.0])
    assert flow_error_px(residuals, parallax_px) == pytest.approx(MAD_TO_SIGMA * 0.5)


def test_too_few_points_near_the_plane_say_nothing():
    residuals = np.full(MIN_NOISE_POINTS, 0.1)
    residuals[0] = 0.7
    assert flow_error_px(residuals, np.ones(MIN_NOISE_POINTS)) is None
    assert flow_error_px(residuals[1:].repeat(2), np.ones(2 * MIN_NOISE_POINTS - 2)) == pytest.approx(
        MAD_TO_SIGMA * 0.1)


@pytest.mark.parametrize("error_px", [0.2, 0.8])
def test_a_level_road_triangulated_from_flow_with_a_known_error_gives_that_error_back(error_px):
    """Road points 1.65 m below a camera (f 500 px) 5-25 m ahead, a 1 m step straight ahead; the second frame's pixels
    moved by Gaussian noise of ``error_px`` in each direction: the fitted plane's residuals read it within 15 %."""
    rng = np.random.default_rng(3)
    K = np.array([[500.0, 0.0, 320.0], [0.0, 500.0, 100.0], [0.0, 0.0, 1.0]])
    road = np.c_[rng.uniform(-3.0, 3.0, 2000), np.full(2000, 1.65), rng.uniform(5.0, 25.0, 2000)]
    seen = road @ K.T
    moved = (road - [0.0, 0.0, 1.0]) @ K.T
    prev_px = seen[:, :2] / seen[:, 2:]
    next_px = moved[:, :2] / moved[:, 2:] + rng.normal(0.0, error_px, (2000, 2))
    motion = EssentialMotion(np.eye(3), np.array([0.0, 0.0, -1.0]), np.ones(2000, bool))
    points = triangulate(prev_px, next_px, K, motion)
    plane = fit_road_plane(points)
    error = flow_error_px(road_residuals(points, plane), translation_parallax_px(prev_px, next_px, K, np.eye(3)))
    assert error == pytest.approx(error_px, rel=0.15)


def test_the_drive_needs_the_fixed_baseline_until_its_flow_errs_more_than_it_allows():
    noise = RoadFlowNoise()
    assert noise.baseline_px(12.0) == 12.0  # nothing seen yet

    def plane_with_error(error_px: float) -> None:
        noise.observe(np.full(MIN_NOISE_POINTS, 0.1), np.full(MIN_NOISE_POINTS, error_px / 0.1 / MAD_TO_SIGMA))

    for error_px in [0.2] * NOISE_PLANES + [0.8] * (NOISE_PLANES // 2 - 1):
        plane_with_error(error_px)
    assert noise.error_px == pytest.approx(0.2)  # the median of the last NOISE_PLANES: most of them 0.2
    assert noise.baseline_px(12.0) == 12.0
    plane_with_error(0.8)
    plane_with_error(0.8)
    assert noise.error_px == pytest.approx(0.8)
    assert noise.baseline_px(12.0) == pytest.approx(BASELINE_SNR * 0.8)


def test_forget_starts_afresh():
    """A mounting taken from the drive: the planes before it were fitted in the wrong frame."""
    noise = RoadFlowNoise()
    noise.observe(np.full(MIN_NOISE_POINTS, 0.1), np.full(MIN_NOISE_POINTS, 8.0))
    assert noise.error_px is not None
    noise.forget()
    assert noise.error_px is None and noise.baseline_px(12.0) == 12.0
    noise.observe(np.full(MIN_NOISE_POINTS, 0.1), np.full(MIN_NOISE_POINTS, 1.0))
    assert noise.error_px == pytest.approx(0.1 * MAD_TO_SIGMA)


def test_run_json_gives_the_error_now_and_at_its_largest_in_the_frames_own_pixels():
    """Working frames at half the frames' size: 2 frame pixels to a working one."""
    noise = RoadFlowNoise()
    assert noise.record(12.0, 2.0) == {"road_flow_error_px": None, "road_flow_error_px_largest": None,
                                       "road_baseline_px_largest": 24.0}
    for error_px in [0.2] * NOISE_PLANES + [0.8] * NOISE_PLANES + [0.3] * NOISE_PLANES:
        noise.observe(np.full(MIN_NOISE_POINTS, 0.1), np.full(MIN_NOISE_POINTS, error_px / 0.1 / MAD_TO_SIGMA))
    assert noise.record(12.0, 2.0) == pytest.approx({"road_flow_error_px": 0.6, "road_flow_error_px_largest": 1.6,
                                                     "road_baseline_px_largest": 2.0 * BASELINE_SNR * 0.8})
    noise.forget()
    assert noise.record(12.0, 2.0)["road_flow_error_px_largest"] is None
