"""The road's normal on a vertical curve: the plane's distance taken under the car, exact on a road of constant
curvature (a sag and a crest, the road's planes measured without noise at a centre ahead)."""

import numpy as np
import pytest

from flowvo.odometry.road_normal import RoadNormal
from flowvo.odometry.road_plane import RoadPlane

HEIGHT_M = 1.65
STEP_M = 1.0
CENTRE_AHEAD_M = 10.0  # where along the road ahead each plane is measured, as the road grid's fits are centred


def _frame(radius_m: float, place_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The road at ``place_m`` along a vertical circle of ``radius_m`` (positive: a sag, the road bends up; world x
    right, y down, z forward at place 0): its point, and its down normal and forward tangent (world, unit)."""
    angle = place_m / radius_m
    point = np.array([0.0, -radius_m * (1.0 - np.cos(angle)), radius_m * np.sin(angle)])
    return point, np.array([0.0, np.cos(angle), np.sin(angle)]), np.array([0.0, -np.sin(angle), np.cos(angle)])


def _camera(radius_m: float, place_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The camera ``HEIGHT_M`` above the road at ``place_m``, level with it: its centre and its axes (columns x, y,
    z in the world)."""
    point, down, forward = _frame(radius_m, place_m)
    return point - HEIGHT_M * down, np.column_stack([np.array([1.0, 0.0, 0.0]), down, forward])


def _drive(road: RoadNormal, radius_m: float, steps: int, height_known: bool) -> list[float]:
    """Drive ``steps`` steps of ``STEP_M`` along the curve, each measuring the tangent plane ``CENTRE_AHEAD_M`` ahead in
    its previous frame (a one-step span, one unit long); each step's camera height as the road gives it (metres)."""
    heights = []
    for step in range(1, steps + 1):
        key_centre, key_axes = _camera(radius_m, (step - 1) * STEP_M)
        _, axes = _camera(radius_m, step * STEP_M)
        R_current_key = axes.T @ key_axes
        road.advance(R_current_key, 0.1, STEP_M)
        point, down, _ = _frame(radius_m, (step - 1) * STEP_M + CENTRE_AHEAD_M)
        normal = key_axes.T @ down
        centre = key_axes.T @ (point - key_centre) / STEP_M  # units of the step
        plane = RoadPlane(float(normal @ centre), normal, 1.0, centre)
        smoothed = road.smoothed(plane, R_current_key, camera_height_m=HEIGHT_M if height_known else None)
        heights.append(smoothed.distance * STEP_M)
    return heights


@pytest.mark.parametrize("radius_m", [1000.0, -1000.0])
def test_on_a_vertical_curve_the_plane_is_taken_under_the_car_and_the_curve_is_measured(radius_m):
    ahead = _drive(RoadNormal(), radius_m, 150, height_known=False)
    # along the blended normal, carried by the rotation alone, a sag puts the car too low and a crest too high
    assert (HEIGHT_M - ahead[-1]) * np.sign(radius_m) > 0.01 * HEIGHT_M
    road = RoadNormal()
    under = _drive(road, radius_m, 150, height_known=True)
    assert under[0] == pytest.approx(ahead[0])  # before the car reaches a road measured ahead: as before
    np.testing.assert_allclose(under[-50:], HEIGHT_M, rtol=2e-3)
    assert road.curvature_per_m == pytest.approx(1.0 / radius_m, rel=0.05)
    assert road.travelled_m == pytest.approx(150 * STEP_M)


def test_on_a_level_road_the_plane_is_the_same_under_the_car():
    road = RoadNormal()
    heights = _drive(road, 1e9, 30, height_known=True)
    np.testing.assert_allclose(heights, HEIGHT_M, rtol=1e-6)


def test_forgetting_the_normal_forgets_the_road_ahead():
    road = RoadNormal()
    _drive(road, 400.0, 20, height_known=True)
    road.forget()
    assert road.normal is None and road.curvature_per_m == 0.0
    heights = _drive(road, 400.0, 1, height_known=True)
    ahead = _drive(RoadNormal(), 400.0, 1, height_known=False)
    assert heights == pytest.approx(ahead)  # nothing measured ahead is under the car any more
