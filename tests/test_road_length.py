"""A step's metric length from the road (flowvo.odometry.road_length.RoadLength): the road plane triangulated from
exact road correspondences (points on a plane projected through a pinhole K), its gates and tally, and the metres
the camera height gives."""

import numpy as np
import pytest

from flowvo.camera import mounting_rotation, pitch_rotation
from flowvo.geometry import so3_exp
from flowvo.odometry.road_length import RoadLength
from flowvo.odometry.two_view import EssentialMotion

K = np.array([[359.0, 0.0, 303.0], [0.0, 359.0, 92.0], [0.0, 0.0, 1.0]])
HEIGHT_M = 1.5
MIN_PARALLAX_PX = 1.0
xs, zs = np.meshgrid(np.linspace(-3.0, 3.0, 9), np.linspace(6.0, 25.0, 12))
ROAD_XZ = np.c_[xs.ravel(), zs.ravel()]  # 108 road points: across (x) and ahead (z), metres


def project(points: np.ndarray) -> np.ndarray:
    pixels = points @ K.T
    return pixels[:, :2] / pixels[:, 2:]


def on_plane(normal: np.ndarray, distance_m: float) -> np.ndarray:
    """The road points (N, 3) moved along y onto the plane ``normal . X = distance_m`` (camera frame)."""
    y = (distance_m - normal[0] * ROAD_XZ[:, 0] - normal[2] * ROAD_XZ[:, 1]) / normal[1]
    return np.c_[ROAD_XZ[:, 0], y, ROAD_XZ[:, 1]]


def seen(road: np.ndarray, length_m: float, yaw_rad: float = 0.01
         ) -> tuple[tuple[np.ndarray, np.ndarray], EssentialMotion]:
    """The road's pixels before and after a step of ``length_m`` forward turning ``yaw_rad``, and the step's
    motion up to scale (unit direction)."""
    R = so3_exp(np.array([0.0, yaw_rad, 0.0]))
    t_dir = -R @ np.array([0.0, 0.0, 1.0])
    return (project(road), project(road @ R.T + t_dir * length_m)), EssentialMotion(R, t_dir, np.ones(1, bool))


def road_length(pitch_deg: float = 0.0, roll_deg: float = 0.0) -> RoadLength:
    return RoadLength(K, HEIGHT_M, pitch_deg, roll_deg, MIN_PARALLAX_PX)


@pytest.mark.parametrize("length_m", [0.3, 1.2])
def test_a_level_road_at_the_camera_height_gives_the_exact_metres(length_m):
    road, motion = seen(on_plane(np.array([0.0, 1.0, 0.0]), HEIGHT_M), length_m)
    plane, road_m = road_length().measure(road, motion, measured=True)
    assert road_m == pytest.approx(length_m, rel=1e-9)
    assert plane.distance == pytest.approx(HEIGHT_M / length_m, rel=1e-9)  # in units of the step
    np.testing.assert_allclose(plane.normal, [0.0, 1.0, 0.0], atol=1e-9)


def test_a_road_plane_tilted_beyond_4_degrees_is_refused_and_tallied_with_its_pitch():
    pitch = np.radians(6.0)
    road, motion = seen(on_plane(np.array([0.0, np.cos(pitch), np.sin(pitch)]), HEIGHT_M), 1.0)
    stage = road_length()
    assert stage.measure(road, motion, measured=True) == (None, None)
    assert stage.tally.trusted == 0
    assert stage.tally.refused_as_tilted == 1 and stage.tally.pitches_deg == [pytest.approx(6.0, abs=1e-6)]


def test_a_road_plane_within_4_degrees_is_trusted_and_tallied():
    pitch = np.radians(3.0)
    road, motion = seen(on_plane(np.array([0.0, np.cos(pitch), np.sin(pitch)]), HEIGHT_M), 1.0)
    stage = road_length()
    plane, road_m = stage.measure(road, motion, measured=True)
    assert road_m == pytest.approx(1.0, rel=1e-9)  # the height is measured along the plane's own normal
    assert plane.tilt_rad == pytest.approx(pitch, rel=1e-6)
    assert stage.tally.record() == {"trusted": 1, "refused_as_tilted": 0,
                                    "candidates_median_pitch_deg": None, "candidates_median_roll_deg": None,
                                    "candidates_pitch_spread_deg": None}


def test_without_a_fit_there_is_no_plane_and_no_length():
    road, _ = seen(on_plane(np.array([0.0, 1.0, 0.0]), HEIGHT_M), 1.0)
    stage = road_length()
    assert stage.measure(road, None, measured=True) == (None, None)
    assert stage.tally.record()["trusted"] == 0


def test_a_road_that_moved_less_than_the_parallax_gate_gives_no_length():
    """A 2 cm step moves nine in ten road points less than 1 px beyond the rotation: no depth to triangulate."""
    road, motion = seen(on_plane(np.array([0.0, 1.0, 0.0]), HEIGHT_M), 0.02)
    assert road_length().measure(road, motion, measured=True) == (None, None)


def test_too_few_road_points_give_no_length():
    (before, after), motion = seen(on_plane(np.array([0.0, 1.0, 0.0]), HEIGHT_M), 1.0)
    assert road_length().measure((before[:19], after[:19]), motion, measured=True) == (None, None)


def test_a_pitched_camera_with_its_levelling_measures_the_road_under_it_exactly():
    """A camera pitched 8 degrees down: its road plane (beyond the 4-degree gate in its own frame) is found
    about the road's normal and comes back in the camera's frame, with the exact metres."""
    levelling = pitch_rotation(8.0)  # R_level_cam
    road_in_camera = on_plane(np.array([0.0, 1.0, 0.0]), HEIGHT_M) @ levelling  # level-frame points, camera frame
    road, motion = seen(road_in_camera, 0.8, yaw_rad=0.0)
    assert road_length().measure(road, motion, measured=True) == (None, None)  # taken for level: refused
    plane, road_m = road_length(8.0).measure(road, motion, measured=True)
    assert road_m == pytest.approx(0.8, rel=1e-9)
    np.testing.assert_allclose(plane.normal, levelling.T @ np.array([0.0, 1.0, 0.0]), atol=1e-9)


def test_a_camera_pitched_8_degrees_down_taken_for_level_is_levelled_by_its_drive_once():
    """Every road plane of a camera pitched 8 degrees down but said level leans 8 degrees and is refused; after
    MIN_TILTED_FOR_HINT of them their median pitch is taken, the next plane is trusted with the exact metres, and
    the planes after it (leaning 0 degrees now) take nothing more: the pitch is a fixed point."""
    from flowvo.odometry.road_tally import MIN_TILTED_FOR_HINT

    road_in_camera = on_plane(np.array([0.0, 1.0, 0.0]), HEIGHT_M) @ pitch_rotation(8.0)
    road, motion = seen(road_in_camera, 0.8, yaw_rad=0.0)
    stage = road_length()
    for _ in range(MIN_TILTED_FOR_HINT - 1):
        assert stage.measure(road, motion, measured=True) == (None, None)
    assert stage.pitches_taken_deg == []
    assert stage.measure(road, motion, measured=True) == (None, None)  # the 20th refused: its pitch is taken
    assert stage.pitches_taken_deg == [pytest.approx(8.0, abs=1e-6)]
    for _ in range(2 * MIN_TILTED_FOR_HINT):
        plane, road_m = stage.measure(road, motion, measured=True)
        assert road_m == pytest.approx(0.8, rel=1e-6)
    assert stage.pitches_taken_deg == [pytest.approx(8.0, abs=1e-6)]
    assert stage.tally.record()["candidates_median_pitch_deg"] == pytest.approx(0.0, abs=1e-4)


@pytest.mark.parametrize("pitch_deg, roll_deg", [(0.0, 7.0), (8.0, -6.0)])
def test_a_rolled_camera_taken_for_level_is_levelled_by_its_drive_once(pitch_deg, roll_deg):
    """A camera rolled (and pitched) but said level: its planes are refused until their pitch and roll are taken,
    exactly (the taken mounting read off the road's normal, not added angle by angle), then every plane is trusted
    with the exact metres and nothing more is taken."""
    from flowvo.odometry.road_tally import MIN_TILTED_FOR_HINT

    road_in_camera = on_plane(np.array([0.0, 1.0, 0.0]), HEIGHT_M) @ mounting_rotation(pitch_deg, roll_deg)
    road, motion = seen(road_in_camera, 0.8, yaw_rad=0.0)
    stage = road_length()
    for _ in range(MIN_TILTED_FOR_HINT):
        assert stage.measure(road, motion, measured=True) == (None, None)
    assert (stage.pitches_taken_deg, stage.rolls_taken_deg) == ([pytest.approx(pitch_deg, abs=1e-6)],
                                                                [pytest.approx(roll_deg, abs=1e-6)])
    for _ in range(2 * MIN_TILTED_FOR_HINT):
        plane, road_m = stage.measure(road, motion, measured=True)
        assert road_m == pytest.approx(0.8, rel=1e-6)
    assert len(stage.pitches_taken_deg) == 1
    np.testing.assert_allclose(plane.normal, mounting_rotation(pitch_deg, roll_deg).T @ [0.0, 1.0, 0.0], atol=1e-6)


@pytest.mark.parametrize("pitch_deg, roll_deg", [(0.0, 7.0), (8.0, -6.0)])
def test_a_rolled_camera_given_the_mounting_its_drive_takes_measures_from_the_first_plane_and_takes_nothing(
        pitch_deg, roll_deg):
    """The mounting a drive takes, given back (``--camera-pitch``, ``--camera-roll``): a fixed point. Every plane is
    trusted with the exact metres from the first, and nothing is taken."""
    from flowvo.odometry.road_tally import MIN_TILTED_FOR_HINT

    road_in_camera = on_plane(np.array([0.0, 1.0, 0.0]), HEIGHT_M) @ mounting_rotation(pitch_deg, roll_deg)
    road, motion = seen(road_in_camera, 0.8, yaw_rad=0.0)
    stage = road_length(pitch_deg, roll_deg)
    for _ in range(3 * MIN_TILTED_FOR_HINT):
        plane, road_m = stage.measure(road, motion, measured=True)
        assert road_m == pytest.approx(0.8, rel=1e-6)
    assert (stage.pitches_taken_deg, stage.rolls_taken_deg) == ([], [])
    np.testing.assert_allclose(plane.normal, mounting_rotation(pitch_deg, roll_deg).T @ [0.0, 1.0, 0.0], atol=1e-6)


def test_a_mounting_taken_from_the_drive_is_taken_back_by_planes_the_gate_trusts():
    """A roll of 6 degrees taken from a stretch of road rolled against the camera (every plane there refused) is the
    drive's estimate: the road after it, rolled 3 degrees, leans 3 degrees back, inside the 4-degree gate, its
    planes trusted, and after 20 of them the roll taken is 3 (a camera given no take needs most planes refused: those
    planes alone would take nothing)."""
    from flowvo.odometry.road_tally import MIN_TILTED_FOR_HINT

    level = on_plane(np.array([0.0, 1.0, 0.0]), HEIGHT_M)
    rolled, motion = seen(level @ mounting_rotation(0.0, 6.0), 0.8, yaw_rad=0.0)
    stage = road_length()
    for _ in range(MIN_TILTED_FOR_HINT):
        stage.measure(rolled, motion, measured=True)
    assert stage.rolls_taken_deg == [pytest.approx(6.0, abs=1e-6)]
    less_rolled, motion = seen(level @ mounting_rotation(0.0, 3.0), 0.8, yaw_rad=0.0)
    for _ in range(MIN_TILTED_FOR_HINT):
        plane, road_m = stage.measure(less_rolled, motion, measured=True)
        assert road_m == pytest.approx(0.8, rel=1e-6)  # trusted
    assert stage.rolls_taken_deg == [pytest.approx(6.0, abs=1e-6), pytest.approx(3.0, abs=1e-6)]
    fresh = road_length()
    for _ in range(2 * MIN_TILTED_FOR_HINT):
        fresh.measure(less_rolled, motion, measured=True)
    assert fresh.rolls_taken_deg == []


def test_the_blended_normal_is_carried_by_the_rotation_and_only_kept_from_measured_flow():
    """A level road, then a road pitched 2 degrees measured poorly (``measured=False``): that plane takes the
    carried normal's blend but leaves it as it was, so the next level road comes back exactly level."""
    stage = road_length()
    level = on_plane(np.array([0.0, 1.0, 0.0]), HEIGHT_M)
    stage.measure(*seen(level, 1.0), measured=True)
    stage.advance(np.eye(3), 0.1, 1.0)
    kept = stage.normal.normal.copy()
    pitch = np.radians(2.0)
    road, motion = seen(on_plane(np.array([0.0, np.cos(pitch), np.sin(pitch)]), HEIGHT_M), 1.0)
    poorly, _ = stage.measure(road, motion, measured=False)
    assert 0.0 < poorly.tilt_rad < pitch  # blended with the carried normal
    np.testing.assert_array_equal(stage.normal.normal, kept)
    stage.forget()
    assert stage.normal.normal is None


def test_a_pitch_taken_from_a_long_tilt_ahead_is_taken_back_by_the_level_road_after_it():
    """Planes leaning 6 degrees for 25 steps (a long ramp seen ahead) are taken for the camera's pitch after 20; the
    level road after them leans -6 degrees against it, and once 20 candidates followed the take (5 of them still on the
    ramp, so after 15 level steps: their median leans -6) the pitch is back at 0."""
    from flowvo.odometry.road_tally import MIN_TILTED_FOR_HINT

    level = on_plane(np.array([0.0, 1.0, 0.0]), HEIGHT_M)
    tilted, motion = seen(level @ pitch_rotation(6.0), 0.8, yaw_rad=0.0)
    stage = road_length()
    for _ in range(MIN_TILTED_FOR_HINT + 5):
        stage.measure(tilted, motion, measured=True)
    assert stage.pitches_taken_deg == [pytest.approx(6.0, abs=1e-6)]
    flat, motion = seen(level, 0.8, yaw_rad=0.0)
    for _ in range(MIN_TILTED_FOR_HINT - 5 - 1):
        assert stage.measure(flat, motion, measured=True) == (None, None)  # refused: it leans -6 degrees now
    stage.measure(flat, motion, measured=True)
    assert stage.pitches_taken_deg == [pytest.approx(6.0, abs=1e-6), pytest.approx(0.0, abs=1e-6)]
    plane, road_m = stage.measure(flat, motion, measured=True)
    assert road_m == pytest.approx(0.8, rel=1e-6)
