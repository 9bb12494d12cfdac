"""The default method's geometry on exact synthetic correspondences: motion, triangulation, road plane."""

import dataclasses

import numpy as np
import pytest

from flowvo.camera import Camera, CameraIntrinsics
from flowvo.geometry import rotation_angle_between_rad, so3_exp
from flowvo.odometry.road_plane import fit_road_plane, is_trusted_road
from flowvo.odometry.road_scale import road_grid, road_points_in_view, road_step_length_m, trusted_road_plane
from flowvo.odometry.two_view import (
    EssentialMotion,
    essential_motion,
    motion_along,
    no_image_area,
    refined_motion,
    textured_points,
    triangulate,
)

K = np.array([[350.0, 0.0, 300.0], [0.0, 350.0, 92.0], [0.0, 0.0, 1.0]])
HEIGHT_M = 1.65


def project(points: np.ndarray) -> np.ndarray:
    """Pixels (N, 2) of camera-frame points (N, 3)."""
    pixels = points @ K.T
    return pixels[:, :2] / pixels[:, 2:]


def scene_and_motion(step_m: float = 1.2, yaw_rad: float = 0.02):
    """Random scene points and road points (camera frame), a motion X2 = R X1 + t of a car moving
    forward ``step_m`` while turning ``yaw_rad``."""
    rng = np.random.default_rng(3)
    scene = np.c_[rng.uniform(-20, 20, 400), rng.uniform(-6, 1.5, 400), rng.uniform(6, 60, 400)]
    road = np.c_[rng.uniform(-3, 3, 300), np.full(300, HEIGHT_M), rng.uniform(5, 25, 300)]
    R = so3_exp(np.array([0.0, yaw_rad, 0.0]))
    t = -R @ np.array([0.0, 0.0, step_m])  # camera centre moves forward by step_m
    return scene, road, R, t


def test_essential_motion_recovers_rotation_and_direction_exactly():
    scene, _, R, t = scene_and_motion()
    fit = essential_motion(project(scene), project(scene @ R.T + t), K, threshold_px=0.25)
    assert fit is not None and fit.inliers.all()
    np.testing.assert_allclose(fit.R, R, atol=1e-6)
    np.testing.assert_allclose(fit.t_dir, t / np.linalg.norm(t), atol=1e-6)


def test_essential_motion_takes_the_intrinsics_as_a_view_of_a_projection_matrix():
    scene, _, R, t = scene_and_motion()
    projection = np.c_[K, np.zeros(3)]  # the left 3x3 of a KITTI P0 is a strided view
    fit = essential_motion(project(scene), project(scene @ R.T + t), projection[:, :3], threshold_px=0.25)
    assert fit is not None
    np.testing.assert_allclose(fit.R, R, atol=1e-6)


def test_refined_motion_returns_the_true_motion_from_a_fit_slightly_off():
    scene, _, R, t = scene_and_motion()
    off_direction = t / np.linalg.norm(t) + np.array([2e-5, -3e-5, 0.0])
    start = EssentialMotion(so3_exp(np.array([1e-5, -2e-5, 1e-5])) @ R, off_direction / np.linalg.norm(off_direction),
                            np.ones(len(scene), bool))  # 0.0015 degrees off, as far as USAC's fits on LK tracks
    refined = refined_motion(project(scene), project(scene @ R.T + t), K, start, scale_px=0.03)
    # one linearisation: what is left is second order and the tracks' float32 pixels (about 1e-8 rad, from 2.4e-5),
    # and in the direction the sideways part, which a forward step measures least, the most
    assert rotation_angle_between_rad(refined.R, R) < 3e-8
    np.testing.assert_allclose(refined.t_dir, t / np.linalg.norm(t), atol=1e-6)
    assert refined.inliers is start.inliers


def test_essential_motion_with_a_robust_scale_is_its_fit_refined():
    scene, _, R, t = scene_and_motion()
    moved = project(scene @ R.T + t) + np.random.default_rng(4).normal(0.0, 0.05, (len(scene), 2))
    fit = essential_motion(project(scene), moved, K, threshold_px=0.25)
    refined = refined_motion(project(scene), moved, K, fit, scale_px=0.06)
    both = essential_motion(project(scene), moved, K, threshold_px=0.25, robust_scale_px=0.06)
    assert not np.array_equal(refined.R, fit.R)
    np.testing.assert_array_equal(both.R, refined.R)
    np.testing.assert_array_equal(both.t_dir, refined.t_dir)


def test_refined_motion_keeps_a_fit_it_would_have_to_turn_far():
    """A linearised refit is a small correction: from a fit a degree off it would move further than
    ``MAX_REFIT_RAD``, and the fit comes back as it was."""
    scene, _, R, t = scene_and_motion()
    start = EssentialMotion(so3_exp(np.array([0.0, np.radians(1.0), 0.0])) @ R, t / np.linalg.norm(t),
                            np.ones(len(scene), bool))
    assert refined_motion(project(scene), project(scene @ R.T + t), K, start, scale_px=0.03) is start


def test_refined_motion_leaves_out_tracks_that_lean_one_way_within_the_threshold():
    """A third of the tracks land 0.1-0.2 px low (the bias of Lucas-Kanade's tracks that USAC's 0.25 px
    threshold keeps), the others within 0.01 px: USAC's fit keeps them all and tilts; the robust refit's rotation
    comes back more than five times closer to the truth, its direction closer too."""
    scene, road, R, t = scene_and_motion()
    points = np.r_[scene, road]
    moved = project(points @ R.T + t)
    rng = np.random.default_rng(2)
    moved += rng.normal(0.0, 0.01, moved.shape)
    leaning = rng.random(len(points)) < 0.35
    moved[leaning, 1] += rng.uniform(0.1, 0.2, leaning.sum())
    fit = essential_motion(project(points), moved, K, threshold_px=0.25)
    assert fit is not None and fit.inliers[leaning].mean() > 0.9
    refined = refined_motion(project(points), moved, K, fit, scale_px=0.03)
    direction = t / np.linalg.norm(t)
    assert rotation_angle_between_rad(refined.R, R) < rotation_angle_between_rad(fit.R, R) / 5
    assert np.linalg.norm(refined.t_dir - direction) < 0.85 * np.linalg.norm(fit.t_dir - direction)


def test_motion_along_a_known_direction_recovers_the_rotation_exactly():
    scene, _, R, t = scene_and_motion()
    direction = -R.T @ t / np.linalg.norm(t)  # of travel, first camera's frame
    start = so3_exp(np.array([0.01, -0.03, 0.005])) @ R  # 1.8 degrees of yaw off, as a sideways fit's
    motion = motion_along(project(scene), project(scene @ R.T + t), K, direction, start, threshold_px=0.25)
    assert motion is not None and motion.inliers.all()
    np.testing.assert_allclose(motion.R, R, atol=1e-9)
    np.testing.assert_allclose(motion.t_dir, t / np.linalg.norm(t), atol=1e-9)


def test_motion_along_a_known_direction_rejects_outliers():
    scene, _, R, t = scene_and_motion()
    moved = project(scene @ R.T + t)
    rng = np.random.default_rng(0)
    outlier = rng.random(len(moved)) < 0.25
    moved[outlier] += rng.uniform(-15.0, 15.0, (outlier.sum(), 2))
    start = so3_exp(np.array([0.01, -0.03, 0.005])) @ R
    motion = motion_along(project(scene), moved, K, -R.T @ t / np.linalg.norm(t), start, threshold_px=0.25)
    assert motion is not None
    assert motion.inliers[~outlier].all() and motion.inliers[outlier].mean() < 0.05  # a few land on their line
    np.testing.assert_allclose(motion.R, R, atol=2e-5)


@pytest.mark.parametrize("start_yaw_rad", [-0.05, -0.02, 0.01, 0.04])
def test_motion_along_finds_the_motion_most_tracks_share_with_a_second_motion_in_view(start_yaw_rad):
    """A third of the tracks move with a second motion (something turning 3 degrees more, as a vehicle
    alongside); from starts up to 3 degrees off, on either side, the rotation most tracks share comes back."""
    scene, _, R, t = scene_and_motion()
    moved = project(scene @ R.T + t)
    other = np.random.default_rng(1).random(len(scene)) < 0.35
    moved[other] = project(scene[other] @ so3_exp(np.array([0.0, 0.05, 0.0])).T + 0.3 * t)
    start = so3_exp(np.array([0.0, start_yaw_rad, 0.0])) @ R
    motion = motion_along(project(scene), moved, K, -R.T @ t / np.linalg.norm(t), start, threshold_px=0.25)
    assert motion is not None and motion.inliers[~other].all() and motion.inliers[other].mean() < 0.1
    np.testing.assert_allclose(motion.R, R, atol=2e-5)  # a few of the others lie on their lines


def test_motion_along_leaves_tracks_without_a_position_out():
    scene, _, R, t = scene_and_motion()
    moved = project(scene @ R.T + t)
    moved[:5] = np.nan  # as a lens model may give far outside its image
    motion = motion_along(project(scene), moved, K, -R.T @ t / np.linalg.norm(t), R, threshold_px=0.25)
    assert motion is not None and not motion.inliers[:5].any() and motion.inliers[5:].all()
    np.testing.assert_allclose(motion.R, R, atol=1e-9)


def test_motion_along_needs_enough_inliers():
    scene, _, R, t = scene_and_motion()
    assert motion_along(project(scene[:20]), project(scene[:20] @ R.T + t), K, np.array([0.0, 0.0, 1.0]), R,
                        threshold_px=0.25) is None


def test_triangulation_returns_points_in_step_units():
    scene, _, R, t = scene_and_motion(step_m=2.0)
    motion = EssentialMotion(R, t / np.linalg.norm(t), np.ones(len(scene), bool))
    points = triangulate(project(scene), project(scene @ R.T + t), K, motion)
    np.testing.assert_allclose(points * 2.0, scene, rtol=1e-6)


def test_road_plane_gives_the_metric_step_from_the_camera_height():
    _, road, R, t = scene_and_motion(step_m=1.37)
    motion = EssentialMotion(R, t / np.linalg.norm(t), np.ones(len(road), bool))
    step = road_step_length_m(project(road), project(road @ R.T + t), K, motion, HEIGHT_M)
    assert step == pytest.approx(1.37, rel=1e-6)


def test_road_plane_ignores_points_above_the_road_and_finds_a_pitched_plane():
    rng = np.random.default_rng(5)
    pitch = np.radians(1.5)
    normal = np.array([0.0, np.cos(pitch), -np.sin(pitch)])
    xz = np.c_[rng.uniform(-3, 3, 300), rng.uniform(5, 25, 300)]
    y = (2.0 - normal[0] * xz[:, 0] - normal[2] * xz[:, 1]) / normal[1]  # n . X = 2
    road = np.c_[xz[:, 0], y, xz[:, 1]]
    boxes = np.c_[rng.uniform(-3, 3, 80), rng.uniform(0.5, 1.2, 80), rng.uniform(5, 25, 80)]  # cars, kerbs
    plane = fit_road_plane(np.r_[road, boxes])
    assert plane.distance == pytest.approx(2.0, rel=1e-9)
    np.testing.assert_allclose(plane.normal, normal, atol=1e-9)
    assert plane.tilt_rad == pytest.approx(pitch, abs=1e-9) and plane.inlier_fraction == pytest.approx(300 / 380)


def test_road_plane_is_carried_by_the_near_road():
    """Triangulated road heights err as the square of the depth (the parallax falls with it): here they run
    high by 0.2 % x (depth / 10 m)^2, 2 % at 32 m, all within the inlier tolerance. Weighing each point by
    depth^-4 keeps the plane within 0.3 % of the true 1.65 m; a plain least-squares plane is 0.6 % off."""
    x, z = (grid.ravel() for grid in np.meshgrid(np.linspace(-3, 3, 13), np.linspace(6, 32, 27)))
    road = np.c_[x, 1.65 * (1 + 0.002 * (z / 10) ** 2), z]
    plane = fit_road_plane(road)
    assert plane.inlier_fraction == 1.0 and plane.distance == pytest.approx(1.65, rel=3e-3)
    centre = road.mean(axis=0)
    normal = np.linalg.svd(road - centre)[2][2]
    assert abs(abs(normal @ centre) / 1.65 - 1) > 5e-3


def test_road_points_that_left_the_frame_are_dropped():
    before = np.array([[300.0, 150.0], [300.0, 180.0], [10.0, 150.0], [600.0, 100.0]], np.float32)
    after = np.array([[301.0, 160.0], [302.0, 190.0], [2.0, 158.0], [618.0, 104.0]], np.float32)
    kept_before, kept_after = road_points_in_view(before, after, (188, 620), margin_px=4)
    np.testing.assert_array_equal(kept_before, before[[0]])  # below, left of and right of the frame: dropped
    np.testing.assert_array_equal(kept_after, after[[0]])


def test_a_slope_ahead_is_not_taken_for_the_road_under_the_camera():
    _, road, R, t = scene_and_motion(step_m=1.0)
    slope = road.copy()
    slope[:, 1] -= np.tan(np.radians(5.0)) * (slope[:, 2] - 5.0)  # rising 5 degrees ahead
    motion = EssentialMotion(R, t / np.linalg.norm(t), np.ones(len(road), bool))
    assert road_step_length_m(project(slope), project(slope @ R.T + t), K, motion, HEIGHT_M) is None


def test_a_camera_pitched_down_finds_its_road_about_the_road_normal():
    """A camera pitched 8 degrees down, moving along the road: its road plane is 8 degrees from the
    camera's down axis, so it fails the 4 degree gate unless the camera says its pitch; then the plane comes
    back exactly, in the camera's frame."""
    _, road_level, _, _ = scene_and_motion()
    camera = Camera(CameraIntrinsics(350.0, 350.0, 300.0, 92.0), pitch_deg=8.0)
    levelling = camera.road_levelling  # camera -> level frame
    road = road_level @ levelling  # the same road points in the pitched camera's frame
    R = levelling.T @ so3_exp(np.array([0.0, 0.02, 0.0])) @ levelling  # a yaw about the road's normal
    t = -R @ (levelling.T @ np.array([0.0, 0.0, 1.3]))  # 1.3 m along the road
    motion = EssentialMotion(R, t / np.linalg.norm(t), np.ones(len(road), bool))
    moved = project(road), project(road @ R.T + t)
    assert trusted_road_plane(*moved, K, motion) is None
    plane = trusted_road_plane(*moved, K, motion, levelling=levelling)
    assert HEIGHT_M / plane.distance == pytest.approx(1.3, rel=1e-6)
    np.testing.assert_allclose(plane.normal, levelling.T @ [0.0, 1.0, 0.0], atol=1e-6)
    assert np.degrees(np.arccos(plane.normal[1])) == pytest.approx(8.0, abs=1e-4)


def test_a_road_whose_flow_is_lost_is_not_trusted_but_a_slow_step_is():
    """A road whose flow is mostly lost (no texture, or a car ahead moving along): its points show a tenth
    of the step (0.57 px of parallax at the 90th percentile) and would give a plane ten times too far.
    Below 1 px no plane is trusted; a real step of 0.3 m (5.9 px) keeps its exact length."""
    _, road, R, t = scene_and_motion(step_m=0.3)
    motion = EssentialMotion(R, t / np.linalg.norm(t), np.ones(len(road), bool))
    lost = project(road @ R.T + 0.1 * t)
    assert trusted_road_plane(project(road), lost, K, motion).distance == pytest.approx(HEIGHT_M / 0.03, rel=1e-6)
    assert trusted_road_plane(project(road), lost, K, motion, min_parallax_px=1.0) is None
    plane = trusted_road_plane(project(road), project(road @ R.T + t), K, motion, min_parallax_px=1.0)
    assert HEIGHT_M / plane.distance == pytest.approx(0.3, rel=1e-6)


def test_a_plane_through_the_camera_is_no_road():
    """Points on the rays of one image row, 2 degrees below the axis, at any depth (scenery at the horizon of a
    camera pitched up and run as if level): they lie on a plane through the camera, tilted 2 degrees, within the
    tilt gate, and all of them fit it. The camera does not look down on it: it is not trusted."""
    _, _, R, t = scene_and_motion(step_m=1.0)
    depth = np.random.default_rng(5).uniform(5.0, 60.0, 200)
    row = np.c_[np.linspace(-0.8, 0.8, 200) * depth, np.tan(np.radians(2.0)) * depth, depth]
    plane = fit_road_plane(row)
    assert abs(plane.distance) < 1e-9 and np.degrees(plane.tilt_rad) == pytest.approx(2.0, abs=1e-6)
    assert plane.inlier_fraction == 1.0 and not is_trusted_road(plane)
    lifted = dataclasses.replace(plane, distance=1e-15)  # as one came out on a synthetic drive, trusted then
    assert not is_trusted_road(lifted)
    motion = EssentialMotion(R, t / np.linalg.norm(t), np.ones(len(row), bool))
    assert trusted_road_plane(project(row), project(row @ R.T + t), K, motion) is None
    road = np.c_[np.linspace(-0.8, 0.8, 200) * depth, np.full(200, HEIGHT_M), depth]  # the road below, for contrast
    assert HEIGHT_M / trusted_road_plane(project(road), project(road @ R.T + t), K, motion).distance == \
        pytest.approx(1.0, rel=1e-6)


def test_no_plane_without_enough_points_below_the_camera():
    assert fit_road_plane(np.array([[0.0, -1.0, 5.0]] * 50)) is None


def test_no_plane_when_no_road_point_is_left():
    _, road, R, t = scene_and_motion(step_m=1.0)
    motion = EssentialMotion(R, t / np.linalg.norm(t), np.ones(len(road), bool))
    none = np.zeros((0, 2), np.float32)
    assert trusted_road_plane(none, none, K, motion, min_parallax_px=1.0) is None


def test_textured_points_pick_corners_not_straight_edges():
    image = np.full((188, 620), 20, np.uint8)
    image[40:56, 100:116] = 255  # one bright square: its four corners are the most corner-like pixels
    image[80:, 200:] = 120  # a long straight edge along row 80 (a strong gradient), with one corner at its end
    image[130:, :] = np.random.default_rng(0).integers(1, 40, (58, 620))  # weak texture below
    points = textured_points(image, count=200)
    assert len(points) == 200 and points.min() >= 0 and (points < [620, 188]).all()
    corners = np.array([[99.5, 39.5], [115.5, 39.5], [99.5, 55.5], [115.5, 55.5]])
    assert (np.abs(corners[:, None] - points[None, :8]).max(axis=2).min(axis=1) <= 0.5).all()  # all among the first
    on_edge = (np.abs(points[:, 1] - 79.5) <= 2) & (points[:, 0] > 210)
    assert not on_edge.any()  # the weak texture's corners rank above every point of the straight edge


def test_textured_points_keep_away_from_areas_without_image():
    image = np.random.default_rng(1).integers(1, 256, (188, 620)).astype(np.uint8)
    image[:, :60] = 0  # a black border, as a lens-warped or letterboxed frame has: its edge is a strong gradient
    image[100, 300] = 0  # a single black pixel is a dark scene, not a missing image
    points = textured_points(image, count=600)
    assert len(points) == 600 and points[:, 0].min() >= 60 + 6
    assert (no_image_area(image)[:, :66]).all() and not no_image_area(image)[:, 70:].any()


def test_road_grid_lies_in_the_band_ahead_of_the_camera():
    road = road_grid((188, 620), K)
    assert road[:, 1].min() >= K[1, 2] + 0.1 * 188 - 1 and road[:, 1].max() <= K[1, 2] + 0.45 * 188
    assert np.abs(road[:, 0] - K[0, 2]).max() <= 0.2 * 620


def test_the_tally_of_road_planes_hints_at_a_pitched_camera_only_when_most_planes_lean_alike():
    from flowvo.odometry.road_plane import RoadPlane
    from flowvo.odometry.road_tally import MIN_TILTED_FOR_HINT, RoadPlaneTally

    def leaning(pitch_deg):
        pitch = np.radians(pitch_deg)
        return RoadPlane(50.0, np.array([0.0, np.cos(pitch), np.sin(pitch)]), 0.5, np.zeros(3))

    tally = RoadPlaneTally()
    for k in range(MIN_TILTED_FOR_HINT + 5):
        tally.add(leaning(8.0 + 0.1 * (k % 3)), trusted=False)
    tally.add(leaning(1.0), trusted=True)
    assert tally.mounting_hint_deg() == pytest.approx((8.1, 0.0))
    assert tally.record() == {"trusted": 1, "refused_as_tilted": MIN_TILTED_FOR_HINT + 5,
                              "candidates_median_pitch_deg": 8.1,
                              "candidates_median_roll_deg": 0.0, "candidates_pitch_spread_deg": 0.2}
    tally.trusted += MIN_TILTED_FOR_HINT + 5  # as many trusted: a hilly drive, not a pitched camera
    assert tally.mounting_hint_deg() is None
    few = RoadPlaneTally()
    few.add(leaning(-9.0), trusted=False)  # refused, but one plane says nothing of the mounting
    assert few.pitches_deg == [pytest.approx(-9.0)] and few.mounting_hint_deg() is None


def test_the_tallys_mounting_is_pending_while_most_planes_are_refused_and_too_few_to_take_it():
    from flowvo.odometry.road_plane import RoadPlane
    from flowvo.odometry.road_tally import MIN_TILTED_FOR_HINT, RoadPlaneTally

    tilted = RoadPlane(50.0, np.array([0.0, np.cos(0.14), np.sin(0.14)]), 0.5, np.zeros(3))  # 8 degrees
    tally = RoadPlaneTally()
    assert not tally.mounting_pending()  # nothing seen yet
    tally.add(tilted, trusted=False)
    assert tally.mounting_pending()
    tally.add(tilted, trusted=True)
    assert not tally.mounting_pending()  # as many trusted as refused
    for _ in range(MIN_TILTED_FOR_HINT - 2):
        tally.add(tilted, trusted=False)
    assert tally.refused_as_tilted == MIN_TILTED_FOR_HINT - 1 and tally.mounting_pending()
    tally.add(tilted, trusted=False)
    assert not tally.mounting_pending()  # enough to judge the mounting from: the hint decides now
    fresh = RoadPlaneTally()
    fresh.add(tilted, trusted=False)
    fresh.restart()  # a mounting was taken from the drive
    fresh.add(tilted, trusted=False)
    assert not fresh.mounting_pending()


def test_the_tally_reads_a_rolled_camera_and_hints_at_its_roll_alone():
    """Planes seen by a camera rolled 6 degrees, right side down (its road's normal in its own frame is
    ``mounting_rotation(0, 6).T @ (0, 1, 0)``), all refused: their roll is 6 degrees and the hint is (0, 6), the
    pitch left as given."""
    from flowvo.camera import mounting_rotation
    from flowvo.odometry.road_plane import RoadPlane
    from flowvo.odometry.road_tally import MIN_TILTED_FOR_HINT, RoadPlaneTally

    tally = RoadPlaneTally()
    for k in range(MIN_TILTED_FOR_HINT):
        normal = mounting_rotation(0.1 * (k % 3), 6.0).T @ np.array([0.0, 1.0, 0.0])
        tally.add(RoadPlane(50.0, normal, 0.5, np.zeros(3)), trusted=False)
    assert tally.rolls_deg[0] == pytest.approx(6.0)
    assert tally.mounting_hint_deg() == (0.0, pytest.approx(6.0, abs=1e-3))


def test_the_pitch_advised_is_a_fixed_point_once_given_and_scattered_planes_advise_nothing():
    """Planes leaning alike about a camera pitched 6 degrees up, and some level ones (most refused): the advice is the
    median of every candidate, not of the refused ones; given it, nothing more is advised. Planes refused but
    scattered over many degrees (the real dash-cam's) say the road's flow is poor, not the mounting: no advice."""
    from flowvo.odometry.road_plane import MAX_ROAD_TILT_RAD, RoadPlane
    from flowvo.odometry.road_tally import RoadPlaneTally

    def tally_of(pitches_deg):
        tally = RoadPlaneTally()
        for pitch_deg in pitches_deg:
            pitch = np.radians(pitch_deg)
            plane = RoadPlane(50.0, np.array([0.0, np.cos(pitch), np.sin(pitch)]), 0.5, np.zeros(3))
            tally.add(plane, trusted=plane.tilt_rad <= MAX_ROAD_TILT_RAD)
        return tally

    alike = np.r_[np.linspace(-0.7, 0.7, 40), np.zeros(10) + 6.0]
    hint_deg, no_roll = tally_of(-6.0 + alike).mounting_hint_deg()
    assert (hint_deg, no_roll) == pytest.approx((np.median(-6.0 + alike), 0.0))
    assert tally_of(-6.0 - hint_deg + alike).mounting_hint_deg() is None
    scattered = tally_of(-3.0 + np.linspace(-9.0, 9.0, 60))  # most refused, over 9 degrees of inter-quartile range
    assert scattered.refused_as_tilted > scattered.trusted and scattered.mounting_hint_deg() is None
    assert scattered.record()["candidates_pitch_spread_deg"] == pytest.approx(9.0, abs=0.2)


def test_after_a_take_planes_through_the_camera_leave_the_mounting_to_the_road_below_it():
    """A wrong take (-8.8 degrees where the camera is pitched up 5) is judged again by the candidates after it: 20 road
    planes below the camera lean 3.8 degrees back, 20 planes through the camera (one grid row's rays) lean -0.5
    degrees. Those are counted but leave the pitches alone, so the road's 3.8 degrees are taken; with them in, the two
    clusters spread over the gate and nothing would be. Before any take, a plane through the camera counts like any
    other."""
    from flowvo.odometry.road_plane import RoadPlane, is_below_camera
    from flowvo.odometry.road_tally import MIN_TILTED_FOR_HINT, RoadPlaneTally

    def leaning(pitch_deg, through_camera=False):
        pitch = np.radians(pitch_deg)
        normal = np.array([0.0, np.cos(pitch), np.sin(pitch)])
        if through_camera:  # a hair's breadth below the camera, its centre far ahead, as the engine's were
            return RoadPlane(1e-15, normal, 0.5, np.array([0.0, 0.0, 30.0]))
        centre = np.array([0.0, 1.0, 20.0])
        return RoadPlane(float(normal @ centre), normal, 0.5, centre)

    assert not is_below_camera(leaning(-0.5, through_camera=True)) and is_below_camera(leaning(3.8))
    tally = RoadPlaneTally()
    tally.add(leaning(-0.5, through_camera=True), trusted=False)
    assert tally.pitches_deg == [pytest.approx(-0.5)]  # no take yet: it counts
    tally.restart()  # a mounting was taken from the drive
    for k in range(MIN_TILTED_FOR_HINT):
        tally.add(leaning(-0.5 + 0.01 * k, through_camera=True), trusted=False)
        tally.add(leaning(3.8 + 0.01 * (k % 3)), trusted=True)
    assert tally.trusted == MIN_TILTED_FOR_HINT and len(tally.pitches_deg) == MIN_TILTED_FOR_HINT
    assert tally.mounting_hint_deg() == pytest.approx((3.81, 0.0))
