"""The road's normal on a vertical curve: the plane's distance taken under the car, exact on a road of constant
curvature (a sag and a crest, the road's planes measured without noise at a centre ahead)."""

import numpy as np
import pytest

from flowvo.odometry.road_normal import RoadNormal
from flowvo.odometry.road_plane import RoadPlane, fit_road_plane

HEIGHT_M = 1.65
STEP_M = 1.0
CENTRE_AHEAD_M = 10.0  # where along the road ahead each plane is measured, as the road grid's fits are centred


def _frame(radius_m: float, place_m: float, curve_ends_m: float = np.inf) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The road at ``place_m`` along a vertical circle of ``radius_m`` (positive: a sag, the road bends up; world x
    right, y down, z forward at place 0) that ends in a straight grade at ``curve_ends_m``: its point, and its down
    normal and forward tangent (world, unit)."""
    angle = min(place_m, curve_ends_m) / radius_m
    point = np.array([0.0, -radius_m * (1.0 - np.cos(angle)), radius_m * np.sin(angle)])
    forward = np.array([0.0, -np.sin(angle), np.cos(angle)])
    point += max(place_m - curve_ends_m, 0.0) * forward
    return point, np.array([0.0, np.cos(angle), np.sin(angle)]), forward


def _camera(radius_m: float, place_m: float, curve_ends_m: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
    """The camera ``HEIGHT_M`` above the road at ``place_m``, level with it: its centre and its axes (columns x, y,
    z in the world)."""
    point, down, forward = _frame(radius_m, place_m, curve_ends_m)
    return point - HEIGHT_M * down, np.column_stack([np.array([1.0, 0.0, 0.0]), down, forward])


def _plane_fitted_ahead(radius_m: float, key_place_m: float, step_m: float, curve_ends_m: float = np.inf) -> RoadPlane:
    """The plane fitted to the road's points 6-30 m ahead of the camera at ``key_place_m``, 3 m to each side (its
    frame, units of the ``step_m`` step)."""
    key_centre, key_axes = _camera(radius_m, key_place_m, curve_ends_m)
    ahead = [_frame(radius_m, key_place_m + d, curve_ends_m)[0] for d in np.linspace(6.0, 30.0, 25)]
    points = np.array([key_axes.T @ (point + np.array([x, 0.0, 0.0]) - key_centre)
                       for point in ahead for x in np.linspace(-3.0, 3.0, 7)]) / step_m
    return fit_road_plane(points, inlier_fraction_of_height=1.0)


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
    assert road.travelled_m == pytest.approx(150 * STEP_M)
    # the blend, a weighted mean of the planes' normals, has the road's tilt at the same mean of their places:
    # behind the last plane's, ahead of the car, within 0.3 m (the places are in the blend's metres, 1.5 % off here;
    # the last plane's place lies 7.6 m further)
    assert 150 * STEP_M < road.place_m < 149 * STEP_M + CENTRE_AHEAD_M - 1.0
    _, axes = _camera(radius_m, 150 * STEP_M)
    there = axes.T @ _frame(radius_m, road.place_m)[1]
    assert np.arccos(min(float(there @ road.normal), 1.0)) < 0.3 / abs(radius_m)


def test_on_a_level_road_the_plane_is_the_same_under_the_car():
    road = RoadNormal()
    heights = _drive(road, 1e9, 30, height_known=True)
    np.testing.assert_allclose(heights, HEIGHT_M, rtol=1e-6)


def test_forgetting_the_normal_forgets_the_road_ahead():
    road = RoadNormal()
    _drive(road, 400.0, 20, height_known=True)
    road.forget()
    assert road.normal is None and road.place_m is None
    heights = _drive(road, 400.0, 1, height_known=True)
    ahead = _drive(RoadNormal(), 400.0, 1, height_known=False)
    assert heights == pytest.approx(ahead)  # nothing measured ahead is under the car any more


def test_a_fitted_planes_tilt_is_the_roads_at_its_slope_depth_and_its_centre_lies_the_curves_rise_off_the_road():
    curvature = 2e-3  # the road bends up ahead: y = h - curvature z^2 / 2 (y down)
    rows = np.arange(100.0, 180.0, 4.0)  # a road grid's rows and columns (pixels, f 359, principal point 92.6 px up)
    depth = 359.0 * HEIGHT_M / (np.repeat(rows, 50) - 92.6)
    across = np.tile(np.arange(-100.0, 100.0, 4.0), len(rows)) * depth / 359.0
    points = np.stack([across, HEIGHT_M - curvature * depth**2 / 2, depth], axis=1)
    plane = fit_road_plane(points, inlier_fraction_of_height=1.0)
    assert plane.slope_depth > plane.centre[2] + 2.0  # the near road weighs most: the tilt is the road's farther on
    assert -plane.normal[2] / plane.normal[1] == pytest.approx(-curvature * plane.slope_depth, rel=1e-3)
    assert plane.centre[1] + curvature * plane.depth_square / 2 == pytest.approx(HEIGHT_M, rel=1e-6)


@pytest.mark.parametrize("radius_m", [1000.0, -1000.0])
def test_planes_fitted_to_a_curved_road_give_the_height_under_the_car(radius_m):
    """Each step fits a plane to road points 6-30 m ahead (the near road weighs most); the blend alone takes the car
    1.5 % too high over a sag and too low over a crest, the plane's centre and its depth in place of the moments 2 %."""
    blend, road = RoadNormal(), RoadNormal()
    heights, blended = [], []
    for step in range(1, 121):
        _, key_axes = _camera(radius_m, (step - 1) * STEP_M)
        _, axes = _camera(radius_m, step * STEP_M)
        R_current_key = axes.T @ key_axes
        road.advance(R_current_key, 0.1, STEP_M)
        blend.advance(R_current_key, 0.1, STEP_M)
        plane = _plane_fitted_ahead(radius_m, (step - 1) * STEP_M, STEP_M)
        heights.append(road.smoothed(plane, R_current_key, camera_height_m=HEIGHT_M).distance * STEP_M)
        blended.append(blend.smoothed(plane, R_current_key).distance * STEP_M)
    assert (blended[-1] - HEIGHT_M) * np.sign(radius_m) > 0.01 * HEIGHT_M
    np.testing.assert_allclose(heights[-30:], HEIGHT_M, rtol=2e-3)


@pytest.mark.parametrize("radius_m", [400.0, -400.0])
def test_after_a_curve_and_a_stretch_without_planes_nothing_of_the_curve_is_carried_on(radius_m):
    """A sharp sag (a crest) ends in a straight grade at 60 m, and the car crawls over 60-68 m measuring no plane (a
    slow stretch, a stop): the blend stays the road's where it was measured, so after it the height is right at
    once. A curve carried on over the stretch without planes took it 5 % off."""
    road, heights = RoadNormal(), {}
    places = np.r_[np.arange(0.0, 60.0, 1.0), np.arange(60.0, 68.0, 0.5), np.arange(68.0, 121.0, 1.0)]
    for key_place, place in zip(places[:-1], places[1:], strict=True):
        _, key_axes = _camera(radius_m, key_place, 60.0)
        _, axes = _camera(radius_m, place, 60.0)
        R_current_key, step_m = axes.T @ key_axes, place - key_place
        road.advance(R_current_key, 0.1, step_m)
        if 60.0 <= key_place < 68.0:
            continue
        plane = _plane_fitted_ahead(radius_m, key_place, step_m, 60.0)
        heights[key_place] = road.smoothed(plane, R_current_key, camera_height_m=HEIGHT_M).distance * step_m
    assert heights[68.0] == pytest.approx(HEIGHT_M, rel=0.01)
    np.testing.assert_allclose([heights[p] for p in np.arange(80.0, 120.0)], HEIGHT_M, rtol=1e-3)
