import hashlib

import cv2
import numpy as np
import pytest

from flowvo.cli import main
from flowvo.geometry import planar_targets, so3_exp
from flowvo.kitti.sequence import KittiSequence
from flowvo.synth.camera_path import generate_path
from flowvo.synth.dataset import sequence_seed, synthesize
from flowvo.synth.render import pixel_rays, render
from flowvo.synth.replay_path import consistent_heights, drivable_heights, levelled
from flowvo.synth.sequence_writer import intrinsics
from flowvo.synth.textures import make_textures
from flowvo.synth.world import World, build_world


@pytest.fixture(scope="module")
def synthetic_root(tmp_path_factory):
    root = tmp_path_factory.mktemp("synth")
    synthesize(root, ["00"], seed=3, frames=20, scale=0.5, gt_flow=True, workers=1)
    return root


def test_layout_is_read_unchanged_by_the_kitti_reader(synthetic_root):
    sequence = KittiSequence(synthetic_root, "00")
    assert len(sequence) == 20
    assert sequence.image_size_hw == (188, 620)
    assert sequence.read_image(0).dtype == np.uint8
    np.testing.assert_allclose(sequence.times_s, 0.1 * np.arange(20), atol=1e-9)
    assert len(sequence.poses) == 20


def test_calibration_is_kitti_intrinsics_scaled(synthetic_root):
    calib = KittiSequence(synthetic_root, "00").calibration
    np.testing.assert_allclose(calib.K0, [[359.428, 0, 303.5964], [0, 359.428, 92.60785], [0, 0, 1]])
    assert calib.baseline_m == pytest.approx(0.54)


def test_pose_file_holds_the_rendered_path_relative_to_its_first_camera(synthetic_root):
    path = generate_path(20, sequence_seed(3, "00"))
    assert abs(path[0, 1, 2]) > 0.01  # the drive starts on a grade: its first camera is pitched in the world
    expected = np.linalg.inv(path[0]) @ path
    np.testing.assert_allclose(KittiSequence(synthetic_root, "00").poses.T_world_cam, expected, atol=1e-8)


def _road_tilt_deg(world: World, T_world_cam: np.ndarray) -> tuple[float, float]:
    """Roll and pitch (degrees) of the ground 5-20 m ahead of the camera, in its frame (plane through
    the world's ground heights below a grid of points 1.65 m under the camera)."""
    across, ahead = np.meshgrid(np.linspace(-3, 3, 7), np.linspace(5, 20, 7))
    points = T_world_cam @ np.stack([across.ravel(), np.full(across.size, 1.65), ahead.ravel(), np.ones(across.size)])
    points[1] = world.lookup(world.ground_y, points[0], points[2])
    in_camera = (np.linalg.inv(T_world_cam) @ points)[:3].T
    normal = np.linalg.svd(in_camera - in_camera.mean(0))[2][2]
    normal *= np.sign(normal[1])
    return float(np.degrees(np.arctan2(-normal[0], normal[1]))), float(np.degrees(np.arctan2(normal[2], normal[1])))


def test_the_road_stays_level_under_the_camera_after_a_turn_from_a_grade():
    """Seed 11 starts on a 4.4 degree grade and has turned 67 degrees by frame 149: a world built in the
    first camera's frame rolled the road 4.6 degrees against the camera there."""
    path = generate_path(150, 11)
    world = build_world(path, 11)
    for frame in (0, 75, 149):
        roll_deg, pitch_deg = _road_tilt_deg(world, path[frame])
        assert abs(roll_deg) < 0.5 and abs(pitch_deg) < 2.0  # jitter 0.34 deg; grade changes ahead


def _straight_grade(grade: float, frames: int = 300) -> np.ndarray:
    """Poses (N, 4, 4) 1 m apart along a straight road of constant ``grade`` (rise over run, up +), each camera
    pitched with the road (y down: the road rises as y falls)."""
    along, up = np.array([0.0, -grade, 1.0]) / np.hypot(1.0, grade), np.array([0.0, 1.0, grade]) / np.hypot(1.0, grade)
    poses = np.tile(np.eye(4), (frames, 1, 1))
    poses[:, :3, 0], poses[:, :3, 1], poses[:, :3, 2] = [1.0, 0.0, 0.0], up, along
    poses[:, :3, 3] = np.arange(frames)[:, None] * np.array([0.0, -grade, 1.0])
    return poses


@pytest.mark.parametrize("grade", [-0.08, 0.0, 0.08])
def test_the_road_ahead_is_rendered_at_its_depth_on_a_climb_and_a_descent(grade):
    """On a constant grade, with the camera pitched along it, the road is the plane 1.65 m below the camera in its
    own frame: a pixel's depth is 1.65 / yn. A fixed-point search for the ground from the level ground under the
    camera diverged where the road ahead rises faster than the ray falls: on an 8 % climb it rendered no road
    beyond 8 m (the horizon's backdrop instead)."""
    poses = _straight_grade(grade)
    world = build_world(poses, 3)
    K, size = intrinsics(0.5)
    rays = pixel_rays(K, size)
    _, depth = render(world, make_textures(3), poses[20], rays)
    column = int(round(K[0, 2]))
    rows = np.arange(size[0])
    yn = (rows - K[1, 2]) / K[1, 1]
    road = (yn > 1.65 / 60.0) & (yn < 1.65 / 5.0)  # 5-60 m ahead, along the path (no hills within 12 m of it)
    np.testing.assert_allclose(depth[road, column], 1.65 / yn[road], rtol=0.002)


@pytest.mark.parametrize("grade", [-0.08, 0.08])
def test_the_road_goes_on_at_its_grade_beyond_the_end_of_the_drive(grade):
    """The last camera of a drive on a constant grade sees the road ahead at its depth, though the drive ends there.
    The world's road had been held level beyond the drive's end, and hills rose from 12 m past it: 32 % nearer at
    38 m even on level ground."""
    poses = _straight_grade(grade, frames=30)
    world = build_world(poses, 3)
    K, size = intrinsics(0.5)
    _, depth = render(world, make_textures(3), poses[-1], pixel_rays(K, size))
    column = int(round(K[0, 2]))
    yn = (np.arange(size[0]) - K[1, 2]) / K[1, 1]
    road = (yn > 1.65 / 40.0) & (yn < 1.65 / 5.0)  # 5-40 m ahead, all of it beyond the drive's last pose
    np.testing.assert_allclose(depth[road, column], 1.65 / yn[road], rtol=0.002)


def test_true_flow_warps_next_frame_onto_current(synthetic_root):
    sequence = KittiSequence(synthetic_root, "00")
    for index in (4, 12, 18):
        current = sequence.read_image(index).astype(np.float32)
        following = sequence.read_image(index + 1).astype(np.float32)
        flow = np.load(synthetic_root / "sequences/00/flow_gt" / f"{index:06d}.npy")
        occluded = cv2.imread(str(synthetic_root / "sequences/00/flow_gt" / f"{index:06d}_occluded.png"), 0) > 0
        assert flow.dtype == np.float32 and flow.shape == (188, 620, 2)
        v, u = np.mgrid[0:188, 0:620].astype(np.float32)
        warped = cv2.remap(following, u + flow[..., 0], v + flow[..., 1], cv2.INTER_LINEAR)
        error = np.abs(warped - current)[~occluded]
        unwarped = np.abs(following - current)[~occluded]
        # measured: mean 1.7-2.2, median 0.5-0.7 grey levels (texture resampling, hard geometric edges)
        assert np.median(error) < 1.5
        assert error.mean() < 3.0
        assert error.mean() < unwarped.mean()


def _digest(root, name="00") -> str:
    files = sorted((root / "sequences" / name / "image_0").glob("*.png"))
    return hashlib.sha256(b"".join(f.read_bytes() for f in files)).hexdigest()


def test_rendering_is_deterministic_per_seed(synthetic_root, tmp_path):
    synthesize(tmp_path / "same", ["00"], seed=3, frames=20, scale=0.5, workers=2)
    synthesize(tmp_path / "other", ["00"], seed=4, frames=20, scale=0.5, workers=1)
    assert _digest(tmp_path / "same") == _digest(synthetic_root)
    assert _digest(tmp_path / "other") != _digest(synthetic_root)


def test_generated_path_respects_speed_and_stays_level_on_average():
    poses = generate_path(600, 1)
    speeds = planar_targets(poses)[:, 0] * 10
    assert speeds.max() <= 25.5 and speeds.min() >= 0.0
    acceleration = np.diff(speeds) * 10
    assert np.abs(acceleration).max() < 3.0


def test_cli_replays_a_real_trajectory(kitti_poses_dir, tmp_path, capsys):
    code = main(["synth", "--out", str(tmp_path), "--sequences", "04", "--trajectory", str(kitti_poses_dir),
                 "--frames", "6", "--scale", "0.25", "--workers", "1", "-q"])
    assert code == 0 and "synthetic" in capsys.readouterr().out
    real = np.loadtxt(kitti_poses_dir / "04.txt")[:6]
    np.testing.assert_allclose(np.loadtxt(tmp_path / "poses" / "04.txt"), real, atol=1e-6)


def test_cli_rejects_missing_trajectory(tmp_path, capsys):
    code = main(["synth", "--out", str(tmp_path), "--trajectory", str(tmp_path / "nope.txt")])
    assert code == 2 and "nope.txt: pose file not found" in capsys.readouterr().err


def test_a_replayed_drive_is_levelled_by_its_cameras_lateral_axes():
    """A generated drive (exact gravity) given in its first camera's frame, as a replayed pose file is:
    the levelled poses put gravity back along y to within the roll jitter, and leave the motions alone."""
    path = generate_path(600, 1021)  # starts on a grade and turns
    replayed = np.linalg.inv(path[0]) @ path
    level = levelled(replayed)
    heading_only = level[0] @ np.linalg.inv(path[0])  # the world frames differ by a rotation about y alone
    assert np.degrees(np.arccos(np.clip(heading_only[1, 1], -1, 1))) < 0.1
    assert np.degrees(np.arccos(path[0, 1, 1])) > 1.0  # the first camera, and so the replayed frame, was tilted
    np.testing.assert_allclose(np.linalg.inv(level[:-1]) @ level[1:], np.linalg.inv(replayed[:-1]) @ replayed[1:],
                               atol=1e-9)


def test_a_replayed_height_the_camera_contradicts_follows_the_camera():
    """KITTI 08's start, reduced: a level camera at walking pace (0.08 m a step) whose ground-truth height rises
    0.18 m a step for 20 steps. The replay's heights follow the camera (level) there, and the rest of the drive
    (a 1 m a step approach) keeps its own height changes, shifted by what was removed."""
    drive = np.repeat(np.eye(4)[None], 41, axis=0)
    step_z = np.r_[np.full(20, 1.0), np.full(20, 0.08)]
    step_up = np.r_[np.full(20, 0.01), np.full(20, 0.18)]  # a 0.6 deg climb, then 66 deg
    drive[1:, 2, 3] = np.cumsum(step_z)
    drive[1:, 1, 3] = -np.cumsum(step_up)
    drivable = drivable_heights(drive)
    np.testing.assert_array_equal(drivable[:21], drive[:21])  # within 5 deg of the camera's axis: kept
    median_offset = np.arctan2(0.01, 1.0)  # of the steps that moved at least 0.1 m horizontally: the 1 m ones
    np.testing.assert_allclose(np.diff(drivable[20:, 1, 3]), -0.08 * np.tan(median_offset), atol=1e-12)
    heights_aside = drivable.copy()
    heights_aside[:, 1, 3] = drive[:, 1, 3]
    np.testing.assert_array_equal(heights_aside, drive)  # horizontal positions and rotations untouched


def test_generated_drives_keep_their_heights_bit_for_bit():
    """Generated drives climb along their cameras' axes (hills of about 15 m): nothing changes, bit for bit."""
    for seed in (3, 1021):
        drive = generate_path(1200, seed)
        assert np.ptp(drive[:, 1, 3]) > 10.0
        np.testing.assert_array_equal(drivable_heights(drive), drive)


def test_a_loop_whose_height_drifted_meets_itself_again():
    """Twice around a 50 m circle at 1 m a step, stopping 20 frames on the way, with a ground-truth height
    that drifts 2 m up per lap (a grade of 0.64 % closes it): afterwards the second lap runs within 0.1 m of
    the first's height where they overlap, the grade changes by at most 1 %, the standstill stays still, and
    only heights change."""
    angle = np.arange(0.0, 2 * np.pi * 1.5, 1.0 / 50.0)
    angle = np.insert(angle, 100, np.full(20, angle[100]))  # a standstill
    drive = np.repeat(np.eye(4)[None], len(angle), axis=0)
    drive[:, 0, 3], drive[:, 2, 3] = 50.0 * np.sin(angle), 50.0 * (1.0 - np.cos(angle))
    drive[:, 1, 3] = -2.0 * angle / (2 * np.pi)
    consistent = consistent_heights(drive)
    lap = np.flatnonzero(angle >= 2 * np.pi)
    first_lap = np.searchsorted(angle, angle[lap] - 2 * np.pi)
    assert np.abs(consistent[lap, 1, 3] - consistent[first_lap, 1, 3]).max() < 0.1
    assert np.abs(drive[lap, 1, 3] - drive[first_lap, 1, 3]).min() > 1.9  # the cliff it would have built
    steps = np.hypot(*np.diff(drive[:, [0, 2], 3], axis=0).T)
    moving = steps > 1e-9
    grade_change = np.diff(consistent[:, 1, 3] - drive[:, 1, 3])[moving] / steps[moving]
    assert np.abs(grade_change).max() < 0.01
    np.testing.assert_allclose(consistent[100:121, 1, 3], consistent[100, 1, 3], atol=1e-9)
    assert consistent[0, 1, 3] == pytest.approx(drive[0, 1, 3], abs=1e-12)
    heights_aside = consistent.copy()
    heights_aside[:, 1, 3] = drive[:, 1, 3]
    np.testing.assert_array_equal(heights_aside, drive)


def test_a_drive_that_never_comes_back_keeps_its_heights():
    drive = generate_path(600, 1021)
    np.testing.assert_array_equal(consistent_heights(drive), drive)


def test_a_drive_that_never_turns_keeps_its_frame_about_the_lateral_axis():
    """Straight along z on a 3 degree climb, camera rolled 2 degrees: the x axes say nothing of the pitch,
    so only the roll is removed."""
    pitch, roll = np.radians(3.0), np.radians(2.0)
    pose = np.eye(4)
    pose[:3, :3] = so3_exp(np.array([pitch, 0.0, 0.0])) @ so3_exp(np.array([0.0, 0.0, roll]))
    drive = np.repeat(pose[None], 20, axis=0)
    drive[:, :3, 3] = np.arange(20)[:, None] * pose[:3, 2]
    level = levelled(drive)
    np.testing.assert_allclose(level[:, 1, 0], 0.0, atol=1e-4)  # the x axes level (0.006 deg: the prior's pull)
    forward = level[0, :3, 2]
    assert np.degrees(np.arcsin(-forward[1])) == pytest.approx(3.0, abs=0.01)  # the climb kept
