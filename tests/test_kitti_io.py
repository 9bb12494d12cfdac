import numpy as np
import pytest
from kitti_layout import make_sequence

from flowvo import geometry as g
from flowvo.errors import FlowvoError
from flowvo.kitti.poses import read_kitti_poses, rotation_to_quaternion_xyzw, write_kitti_poses, write_tum_trajectory
from flowvo.kitti.sequence import KittiSequence
from flowvo.trajectory import Trajectory


def sample_trajectory() -> Trajectory:
    rng = np.random.default_rng(0)
    return Trajectory.from_poses(g.chain_se3(g.se3_from_targets(rng.normal(scale=0.2, size=(4, 6)))))


def test_pose_file_round_trip_plain_form(tmp_path):
    trajectory = sample_trajectory()
    write_kitti_poses(tmp_path / "p.txt", trajectory)
    assert len((tmp_path / "p.txt").read_text().splitlines()[0].split()) == 12
    back = read_kitti_poses(tmp_path / "p.txt")
    np.testing.assert_allclose(back.T_world_cam, trajectory.T_world_cam, atol=1e-8)


def test_pose_file_with_missing_frames_uses_frame_index_form(tmp_path):
    trajectory = sample_trajectory().subset(np.array([0, 2, 4]))
    write_kitti_poses(tmp_path / "p.txt", trajectory)
    first = (tmp_path / "p.txt").read_text().splitlines()[1].split()
    assert first[0] == "2" and len(first) == 13
    np.testing.assert_array_equal(read_kitti_poses(tmp_path / "p.txt").frame_ids, [0, 2, 4])


@pytest.mark.parametrize(
    "content, message",
    [
        ("1 0 0 0 0 1 0 0 0 0 1\n", r"p.txt:1: expected 12 numbers .* found 11"),
        ("1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 x\n", r"p.txt:2: .*found text"),
        ("1 0 0 0 0 1 0 0 0 0 1 0\n1 1 0 0 0 1 0 0 0 0 1 0 3\n", r"p.txt:2: mixes"),
        ("2 1 0 0 0 0 1 0 0 0 0 1 0\n1 1 0 0 0 0 1 0 0 0 0 1 0\n", r"p.txt:2: frame index 1 is not increasing"),
        ("2 0 0 0 0 1 0 0 0 0 1 0\n", r"p.txt:1: rotation part is not orthonormal"),
        ("", r"p.txt: pose file is empty"),
    ],
)
def test_malformed_pose_files_name_file_and_line(tmp_path, content, message):
    (tmp_path / "p.txt").write_text(content)
    with pytest.raises(FlowvoError, match=message):
        read_kitti_poses(tmp_path / "p.txt")


def test_tum_file_has_the_given_timestamps_and_unit_quaternions(tmp_path):
    trajectory = sample_trajectory()
    times_s = np.array([0.0, 0.103751, 0.207502, 0.311252, 0.415003])  # real KITTI times.txt spacing
    write_tum_trajectory(tmp_path / "t.tum", trajectory, times_s)
    rows = np.loadtxt(tmp_path / "t.tum")
    np.testing.assert_allclose(rows[:, 0], times_s)
    np.testing.assert_allclose(rows[:, 1:4], trajectory.positions, atol=1e-8)
    np.testing.assert_allclose(np.linalg.norm(rows[:, 4:], axis=1), 1.0)


def test_quaternion_of_known_rotation():
    q = rotation_to_quaternion_xyzw(g.so3_exp(np.array([0.0, np.pi / 2, 0.0])))
    np.testing.assert_allclose(q, [0, np.sqrt(0.5), 0, np.sqrt(0.5)], atol=1e-12)


def test_sequence_reads_frames_lazily_and_calibration(tmp_path):
    make_sequence(tmp_path, n_frames=3)
    sequence = KittiSequence(tmp_path, "0")
    assert len(sequence) == 3 and sequence.image_size_hw == (8, 12)
    assert sequence.read_image(2)[0, 0] == 20
    assert sequence.calibration.K0[0, 0] == 700.0
    assert sequence.calibration.baseline_m == pytest.approx(0.54)
    assert len(sequence.poses) == 3


def test_missing_frame_is_reported(tmp_path):
    seq = make_sequence(tmp_path, n_frames=3)
    (seq / "image_0" / "000001.png").unlink()
    with pytest.raises(FlowvoError, match="frame 000001.png is missing"):
        KittiSequence(tmp_path, "00")


def test_image_of_other_size_is_reported(tmp_path):
    seq = make_sequence(tmp_path, n_frames=3)
    import cv2

    cv2.imwrite(str(seq / "image_0" / "000002.png"), np.zeros((9, 12), np.uint8))
    with pytest.raises(FlowvoError, match=r"000002.png: image is 12x9, the sequence's first is 12x8"):
        KittiSequence(tmp_path, "00")


def test_times_and_pose_counts_must_match_frames(tmp_path):
    seq = make_sequence(tmp_path, n_frames=3)
    (tmp_path / "poses" / "00.txt").write_text("1 0 0 0 0 1 0 0 0 0 1 0\n" * 2)
    with pytest.raises(FlowvoError, match=r"00.txt: has 2 poses for 3 frames"):
        _ = KittiSequence(tmp_path, "00").poses
    (seq / "times.txt").write_text("0.0\n")
    with pytest.raises(FlowvoError, match=r"times.txt: has 1 timestamps for 3 frames"):
        KittiSequence(tmp_path, "00")


def test_malformed_calibration_names_line(tmp_path):
    seq = make_sequence(tmp_path)
    (seq / "calib.txt").write_text("P0: 1 2 3\n")
    with pytest.raises(FlowvoError, match=r"calib.txt:1: P0: expected 12 numbers, found 3"):
        _ = KittiSequence(tmp_path, "00").calibration
