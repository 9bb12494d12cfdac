"""The road's flow (flowvo.odometry.road_flow.RoadFlow): a textured frame moved by the exact homography of a flat
road under a step (1 degree of turn; 0.3 m, within DIS's reach, and 1.5 m, beyond it) gives road grid points moved
by that homography, measured as it is and through a predicted homography, with and without a lens."""

import warnings

import cv2
import numpy as np
import pytest

from flowvo.camera import (
    Camera,
    CameraIntrinsics,
    LensDistortion,
    distort_points,
    mounting_rotation,
    undistort_points,
)
from flowvo.geometry import so3_exp
from flowvo.odometry.road_flow import RoadFlow
from flowvo.odometry.road_plane import RoadPlane
from flowvo.odometry.road_scale import GRID_MARGIN_PX, horizon_below_px, road_homography, road_top_shift_px
from flowvo.odometry.two_view import EssentialMotion

HW = (188, 620)
INTRINSICS = CameraIntrinsics(359.0, 359.0, 303.0, 92.0)
K = INTRINSICS.K
HEIGHT_M = 1.5
LENS = LensDistortion("plumb_bob", (-0.25, 0.07, 0.0, 0.0))
TURN = so3_exp(np.array([0.0, np.radians(1.0), 0.0]))
STEP = EssentialMotion(TURN, -TURN @ np.array([0.0, 0.0, 1.0]), np.ones(1, bool))
texture = np.random.default_rng(3).uniform(0, 255, (HW[0] // 2, HW[1] // 2)).astype(np.float32)
PREVIOUS = cv2.GaussianBlur(cv2.resize(texture, HW[::-1], interpolation=cv2.INTER_CUBIC), (0, 0), 1.0)


def road_moved_by(length_m: float) -> np.ndarray:
    """The homography (undistorted pixels) of the road 1.5 m below the camera under a ``length_m`` step."""
    return road_homography(K, STEP, RoadPlane.level(HEIGHT_M / length_m))


def transform(points_px: np.ndarray, H: np.ndarray) -> np.ndarray:
    pixels = np.c_[points_px, np.ones(len(points_px))] @ H.T
    return pixels[:, :2] / pixels[:, 2:]


def frames(H: np.ndarray, lens: LensDistortion) -> tuple[np.ndarray, np.ndarray]:
    """The textured frame and the frame it becomes when every undistorted pixel p moves to ``H p``, both seen
    through ``lens``, uint8."""
    if lens.is_none:
        current = cv2.warpPerspective(PREVIOUS, H, HW[::-1], flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
    else:
        rows, columns = np.mgrid[0:HW[0], 0:HW[1]]
        ideal = undistort_points(np.stack([columns.ravel(), rows.ravel()], axis=1).astype(np.float32), K, lens)
        source = distort_points(transform(ideal, np.linalg.inv(H)), K, lens).astype(np.float32).reshape(*HW, 2)
        current = cv2.remap(PREVIOUS, source[..., 0], source[..., 1], cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
    return PREVIOUS.clip(0, 255).astype(np.uint8), current.clip(0, 255).astype(np.uint8)


def errors_px(lens: LensDistortion, length_m: float, predicted_m: float | None) -> tuple[np.ndarray, RoadFlow]:
    """How far each road point RoadFlow gives lies from where the exact homography moved it (pixels)."""
    road = RoadFlow(Camera(INTRINSICS, lens, HEIGHT_M), HW, "dis-road")
    H = road_moved_by(length_m)
    before, after = road.measure(*frames(H, lens), None if predicted_m is None else road_moved_by(predicted_m))
    return np.linalg.norm(after - transform(before, H), axis=1), road


@pytest.mark.parametrize("lens", [LensDistortion(), LENS], ids=["pinhole", "lens"])
def test_a_short_step_measured_without_a_prediction_moves_the_road_by_its_homography(lens):
    """0.3 m: the road moves 6-10 px (median, 90th percentile), within DIS's reach; measured 0.05 / 0.09 px."""
    error, road = errors_px(lens, 0.3, None)
    assert len(error) == len(road.grid_px)  # no road point left the frame
    assert np.median(error) < 0.1 and np.percentile(error, 90) < 0.2


@pytest.mark.parametrize("lens", [LensDistortion(), LENS], ids=["pinhole", "lens"])
def test_a_long_step_measured_through_the_exact_prediction_moves_the_road_by_its_homography(lens):
    """1.5 m: the near road moves 25-30 px, beyond DIS's reach (measured as it is, one point in ten is off by
    over a pixel); through the exact prediction DIS measures only the residual: 0.01 / 0.02 px."""
    error, _ = errors_px(lens, 1.5, 1.5)
    assert np.median(error) < 0.02 and np.percentile(error, 90) < 0.04 and error.max() < 0.3
    unpredicted, _ = errors_px(lens, 1.5, None)
    assert np.percentile(unpredicted, 90) > 1.0


def test_a_prediction_5_percent_long_leaves_a_residual_dis_measures():
    error, _ = errors_px(LensDistortion(), 1.5, 1.5 * 1.05)  # measured: 0.03 / 0.05 px
    assert np.median(error) < 0.05 and np.percentile(error, 90) < 0.1


def test_a_prediction_that_sends_part_of_the_crop_to_infinity_through_a_lens_warns_of_nothing():
    """A prediction whose horizon crosses the road crop (a wrong speed or normal, say) maps the pixels next to it to
    millions of focal lengths away, where a lens with a sixth-order term overflowed float32 (a RuntimeWarning on the
    user's console); those pixels now read the frame's border."""
    lens = LensDistortion("plumb_bob", (-0.25, 0.07, 0.0, 0.0, -0.1))
    road = RoadFlow(Camera(INTRINSICS, lens, HEIGHT_M), HW, "dis-road")
    ideal_y = float(road.view().ideal_px[40 * HW[1], 1])  # a pixel of the crop's 40th row, undistorted
    horizon = (ideal_y - K[1, 2]) / K[1, 1] * (1.0 + 3e-7)  # its normalised row, just past the prediction's horizon
    prediction = K @ np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0 / horizon, 1.0]]) @ np.linalg.inv(K)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        before, after = road.measure(*frames(road_moved_by(0.3), lens), prediction)
    assert np.isfinite(before).all() and np.isfinite(after).all()


def test_road_points_that_leave_the_frame_are_dropped():
    """On the 1.5 m step the nearest road leaves the frame: those points are not given back, and every point
    given back lies inside the frame, ``GRID_MARGIN_PX`` from its edges."""
    road = RoadFlow(Camera(INTRINSICS, height_m=HEIGHT_M), HW, "dis-road")
    H = road_moved_by(1.5)
    before, after = road.measure(*frames(H, LensDistortion()), H)
    inside = transform(road.grid_undistorted_px, H)
    inside = ((inside >= GRID_MARGIN_PX) & (inside < np.array(HW[::-1]) - GRID_MARGIN_PX)).all(axis=1)
    assert 0 < len(before) < len(road.grid_px)
    np.testing.assert_array_equal(before, road.grid_undistorted_px[inside])
    assert ((after >= GRID_MARGIN_PX) & (after < np.array(HW[::-1]) - GRID_MARGIN_PX)).all()


@pytest.mark.parametrize("pitch_deg", [-5.0, 0.0, 8.0])
def test_the_road_grid_and_crop_start_below_the_horizon_of_a_camera_pitched_up(pitch_deg):
    """A camera pitched 5 degrees up has its horizon fy tan(5 deg) below the principal point: the grid's and the
    crop's top rows move down until the grid's top is 0.05 frame heights below it; level and pitched-down cameras keep
    theirs (their horizon is higher). A still layer over the road is judged from the level camera's top all the same
    (a reflection's dots lie there)."""
    K = np.array([[359.0, 0.0, 310.0], [0.0, 359.0, 94.0], [0.0, 0.0, 1.0]])
    intrinsics = CameraIntrinsics(359.0, 359.0, 310.0, 94.0)
    level = RoadFlow(Camera(intrinsics), (188, 620), "dis-road")
    road = RoadFlow(Camera(intrinsics, pitch_deg=pitch_deg), (188, 620), "dis-road")
    horizon = 359.0 * np.tan(np.radians(5.0)) if pitch_deg < 0 else 0.0
    assert horizon_below_px(K, pitch_deg) == pytest.approx(horizon, abs=1e-9)
    below = max(0.0, horizon - 0.05 * 188)  # 22.0 px for the camera pitched up
    if pitch_deg < 0:  # the grid's top row lies 0.05 frame heights under the horizon, to the pixel
        assert abs(road.grid_px[:, 1].min() - (94.0 + horizon + 0.05 * 188)) < 1.0
    assert road.grid_px[:, 1].min() == int(94.0 + below + 0.10 * 188)
    assert road.crop[0].start == int(94.0 + below + 0.05 * 188)
    assert 0 <= level.grid_px[:, 1].max() - road.grid_px[:, 1].max() < GRID_MARGIN_PX  # the grid's step from its top
    assert road.crop[0].stop == level.crop[0].stop
    assert road.from_level_top() == (slice(int(94.0 + 0.05 * 188), road.crop[0].stop), road.crop[1])
    # its still points are judged in the grid's near half (a camera pitched up has a shorter grid)
    assert road.still.first_row == pytest.approx(94.0 + (below + 0.55 * 188) / 2, abs=1e-9)
    placed = RoadFlow(Camera(intrinsics), (188, 620), "dis-road")  # a level camera whose pitch the drive says
    assert placed.place(pitch_deg) and placed.top_shift_px == pytest.approx(below, abs=1e-9)
    np.testing.assert_array_equal(placed.grid_px, road.grid_px)
    assert (placed.crop, placed.crop_hw, placed.still.first_row) == (road.crop, road.crop_hw, road.still.first_row)


@pytest.mark.parametrize(("horizon_px", "shift_px"), [(0.0, 0.0), (9.0, 0.0), (10.0, 0.0), (10.5, 0.5), (31.4, 21.4)])
def test_the_road_grid_moves_down_only_as_far_as_keeps_its_top_below_the_horizon(horizon_px, shift_px):
    """Frames 200 px high: a level camera's grid starts 20 px under the principal point, and it stays there while the
    horizon is 10 px (0.05 frame heights) or more above it (a camera pitched up 1.8 degrees, as the real dash-cam);
    below that it moves down with the horizon."""
    assert road_top_shift_px(horizon_px, 200) == pytest.approx(shift_px, abs=1e-12)


def test_a_camera_pitched_up_a_little_keeps_the_level_cameras_road_grid():
    """The real dash-cam's calibration at 620 px: pitched 1.5 degrees up, its road grid and crop are the level
    camera's; at its own pitch, 1.8 degrees up (the horizon 0.05 frame heights under the principal point), they move
    down by a fraction of a pixel (before, by 17.6 px: they lost their farthest rows above its bonnet, and the run told
    its pitch read 7 % faster than run level)."""
    intrinsics = CameraIntrinsics(561.0, 559.0, 324.0, 188.0)
    level = RoadFlow(Camera(intrinsics), (349, 620), "dis-road")
    told = RoadFlow(Camera(intrinsics, pitch_deg=-1.5), (349, 620), "dis-road")
    assert 0.0 < horizon_below_px(intrinsics.K, -1.5) < 0.05 * 349
    np.testing.assert_array_equal(told.grid_px, level.grid_px)
    assert told.crop == level.crop and told.top_shift_px == 0.0
    at_its_pitch = RoadFlow(Camera(intrinsics, pitch_deg=-1.8), (349, 620), "dis-road")
    assert 17.0 < horizon_below_px(intrinsics.K, -1.8) and 0.0 < at_its_pitch.top_shift_px < 0.5


@pytest.mark.parametrize(("pitch_deg", "roll_deg"), [(0.0, 6.0), (0.0, -6.0), (-2.0, 4.0), (3.0, -7.0)])
def test_a_rolled_camera_has_its_road_crop_start_below_the_lowest_point_of_its_sloping_horizon(pitch_deg, roll_deg):
    """A rolled camera's horizon slopes: at the crop's side that it is lowest on, the pixel ``horizon_below_px`` under
    the principal point looks parallel to the road (its ray is at right angles to the road's normal), and the other
    side's horizon lies higher; rolled 6 degrees and level, that is the crop's half width times tan(6 deg)."""
    half_width_px = 0.25 * 620
    below = horizon_below_px(K, pitch_deg, roll_deg, half_width_px)
    normal = mounting_rotation(pitch_deg, roll_deg).T @ np.array([0.0, 1.0, 0.0])
    sides = [np.linalg.inv(K) @ np.array([K[0, 2] + side * half_width_px, K[1, 2] + below, 1.0]) for side in (-1, 1)]
    low, high = sorted(sides, key=lambda ray: abs(ray @ normal))
    assert below > 0 and low @ normal == pytest.approx(0.0, abs=1e-12) and high @ normal > 0.01  # the other side's
    # pixel looks at the road: its horizon is higher
    if pitch_deg == 0.0:
        assert below == pytest.approx(half_width_px * np.tan(np.radians(abs(roll_deg))), rel=1e-12)
    road = RoadFlow(Camera(INTRINSICS), HW, "dis-road")
    shift = max(0.0, below - 0.05 * HW[0])  # the grid's top 0.05 frame heights under the horizon's lowest point
    assert road.place(pitch_deg, roll_deg) and road.top_shift_px == pytest.approx(shift, abs=1e-9)
    assert road.crop[0].start == int(K[1, 2] + shift + 0.05 * HW[0])
    assert road.grid_px[:, 1].min() == int(K[1, 2] + shift + 0.10 * HW[0])


def test_a_road_crop_placed_too_small_for_the_flow_is_not_placed():
    """A camera said to look 25 degrees up would keep a crop of a few rows: the crop and grid stay as they were."""
    road = RoadFlow(Camera(CameraIntrinsics(359.0, 359.0, 310.0, 94.0)), (188, 620), "dis-road")
    grid, crop = road.grid_px.copy(), road.crop
    assert not road.place(-25.0, min_side_px=32)
    np.testing.assert_array_equal(road.grid_px, grid)
    assert road.crop == crop and road.top_shift_px == 0.0


def test_a_view_that_ends_above_a_bonnet_keeps_its_paint_out_of_the_road_flow():
    """The frames' view ends at row 170 (a bonnet found below it): the road crop and grid stop there as at the frame's
    bottom edge, so the same step with a bonnet painted from that row down is measured exactly as without it, and
    every road point given back lies ``GRID_MARGIN_PX`` above the view's end in both frames. Over the whole frame the
    grid reaches into the paint."""
    bottom = 170
    H = road_moved_by(1.5)
    previous, current = frames(H, LensDistortion())
    paint = np.random.default_rng(7).uniform(150, 250, (HW[0] - bottom, HW[1])).astype(np.uint8)
    painted = [np.vstack([image[:bottom], paint]) for image in (previous, current)]
    camera = Camera(INTRINSICS, height_m=HEIGHT_M)
    before, after = RoadFlow(camera, HW, "dis-road").measure(*painted, H, bottom_px=bottom)
    clean_before, clean_after = RoadFlow(camera, HW, "dis-road").measure(previous, current, H, bottom_px=bottom)
    np.testing.assert_array_equal(before, clean_before)
    np.testing.assert_array_equal(after, clean_after)
    assert len(before) and (before[:, 1] < bottom - GRID_MARGIN_PX).all()
    assert (after[:, 1] < bottom - GRID_MARGIN_PX).all()
    whole_before, whole_after = RoadFlow(camera, HW, "dis-road").measure(*painted, H)
    assert len(whole_before) > len(before)
