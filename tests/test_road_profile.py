"""Where the ground beside and ahead of the road is not level with it (flowvo.odometry.road_profile): cells whose
points stand persistently off the trusted planes are left out of the plane fit, on exact road points."""

import numpy as np
import pytest

from flowvo.geometry import so3_exp
from flowvo.odometry.road_length import RoadLength
from flowvo.odometry.road_plane import RoadPlane, fit_road_plane
from flowvo.odometry.road_profile import MIN_CELL_POINTS, MIN_CELL_STEPS, RoadProfile, cell_medians, ground_cells
from flowvo.odometry.two_view import EssentialMotion

K = np.array([[359.0, 0.0, 303.0], [0.0, 359.0, 92.0], [0.0, 0.0, 1.0]])
HEIGHT_M = 1.5
KERB_M = 0.044  # pavements this much above the road: inside the plane fit's inlier band (3 % of the height)
xs, zs = np.meshgrid(np.linspace(-3.6, 3.6, 25), np.linspace(6.0, 25.0, 40))
GROUND = np.c_[xs.ravel(), np.full(xs.size, HEIGHT_M), zs.ravel()]  # camera frame, y down, metres
PAVEMENT = np.abs(GROUND[:, 0]) > 3.1  # both sides beyond 3.1 m (2.07 heights: its own cells, 2-2.5 heights out)
GROUND[PAVEMENT, 1] -= KERB_M


def test_cell_medians_are_each_cells_median_and_nan_for_too_few_points():
    residuals = np.array([5.0, 1.0, 3.0, 2.0, 4.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 7.0])
    cells = np.array([3, 3, 3, 3, 3, 8, 8, 8, 8, 8, 8, 0])
    medians = cell_medians(residuals, cells)
    assert medians[3] == 3.0 and medians[8] == 35.0  # odd and even counts
    assert np.isnan(medians[0]) and MIN_CELL_POINTS > 1  # one point says nothing of its cell
    assert np.isnan(np.delete(medians, [3, 8])).all()


def test_the_pavement_is_left_out_after_its_cells_were_seen_in_enough_steps():
    profile = RoadProfile()
    plane = fit_road_plane(GROUND)
    for _ in range(MIN_CELL_STEPS):
        assert profile.keep(GROUND).all()  # nothing is judged before MIN_CELL_STEPS steps
        profile.observe(GROUND, plane)
    off = ~profile.keep(GROUND)
    assert off[PAVEMENT].all() and not off[np.abs(GROUND[:, 0]) < 2.9].any()  # the cells 2-2.5 heights out: the
    # pavement and the road's edge at 3 m
    level = fit_road_plane(GROUND[profile.keep(GROUND)])
    assert level.distance == pytest.approx(HEIGHT_M, abs=1e-9)  # the road alone: exactly level
    np.testing.assert_allclose(level.normal, [0.0, 1.0, 0.0], atol=1e-9)
    assert abs(plane.distance - HEIGHT_M) > 4e-3  # with the pavement the plane rose and rolled
    assert profile.record() == {"ground_cells_off_road": 10,  # one a side in each of the 5 depth bands seen
                                "far_road_off_plane_share": pytest.approx(HEIGHT_M / plane.distance - 1.0, abs=1e-4)}
    profile.forget()
    assert profile.keep(GROUND).all()
    assert profile.record() == {"ground_cells_off_road": 0, "far_road_off_plane_share": None}


def test_a_profile_that_would_leave_too_few_points_keeps_them_all():
    profile = RoadProfile()
    profile.off_road[:] = True
    assert profile.keep(GROUND).all()


def test_the_road_length_comes_out_exact_once_the_pavement_is_left_out():
    """A 0.8 m step over the road and the pavement beside it: the first steps' planes lean on the pavement (lengths
    off), the later ones measure the road alone, exactly."""
    R = so3_exp(np.zeros(3))
    t_dir = np.array([0.0, 0.0, -1.0])

    def project(points):
        pixels = points @ K.T
        return pixels[:, :2] / pixels[:, 2:]

    road = project(GROUND), project(GROUND + t_dir * 0.8)
    stage = RoadLength(K, HEIGHT_M, 0.0, 0.0, 1.0)
    lengths = [stage.measure(road, EssentialMotion(R, t_dir, np.ones(1, bool)), measured=False)[1]
               for _ in range(MIN_CELL_STEPS + 1)]
    assert abs(lengths[0] - 0.8) > 2e-3
    assert lengths[-1] == pytest.approx(0.8, rel=1e-9)
    assert isinstance(stage.profile.off_road, np.ndarray) and stage.profile.off_road.any()


def test_ground_cells_count_depth_and_side_in_camera_heights():
    points = np.array([[0.1, 1.0, 4.0], [0.1, 2.0, 8.0], [-0.1, 1.0, 4.0], [7.0, 1.0, 30.0]])
    cells = ground_cells(points, 1.0)
    assert cells[0] != cells[2]  # either side of the camera's axis
    assert cells[0] != cells[1]  # a band deeper
    assert ground_cells(points * 2.0, 2.0).tolist() == cells.tolist()  # in units of the height


def test_road_points_that_bend_away_from_the_near_road_plane_are_measured_straight_ahead():
    """Road points 10-20 heights ahead lying 30 % of the height below the plane through the nearer ones (the real
    dash-cam's bowl, docs/dashcam.md): the far road's share reads 0.3; a flat road reads 0."""
    bowl = GROUND.copy()
    far = (bowl[:, 2] >= 10 * HEIGHT_M) & (bowl[:, 2] < 20 * HEIGHT_M)
    bowl[far, 1] += 0.3 * HEIGHT_M
    profile, flat = RoadProfile(), RoadProfile()
    for _ in range(MIN_CELL_STEPS):
        profile.observe(bowl, RoadPlane.level(HEIGHT_M))
        flat.observe(GROUND, RoadPlane.level(HEIGHT_M))
    assert profile.far_road_share() == pytest.approx(0.3)
    assert flat.far_road_share() == pytest.approx(0.0)
