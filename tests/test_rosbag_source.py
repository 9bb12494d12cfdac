"""ROS bag frame source: frames, stamps and intrinsics round-trip through every bag kind; bad bags fail early."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("rosbags")

from ros_bags import KINDS, BagSpec, write_bag  # noqa: E402

from flowvo.camera import CameraIntrinsics  # noqa: E402
from flowvo.errors import FlowvoError  # noqa: E402
from flowvo.kitti.sequence import KittiSequence  # noqa: E402
from flowvo.ros import extra  # noqa: E402
from flowvo.ros.camera_info import CameraInfoError, camera_info_intrinsics, is_rectified_topic  # noqa: E402
from flowvo.ros.images import ImageMessageError, compressed_image_to_grey, raw_image_to_grey  # noqa: E402
from flowvo.sources.rosbag import open_bag_source  # noqa: E402
from flowvo.synth.dataset import synthesize  # noqa: E402

TOPIC = "/camera/image_raw"
INFO_TOPIC = "/camera/camera_info"


@pytest.fixture(scope="module")
def kitti(tmp_path_factory) -> KittiSequence:
    """A tiny synthetic drive in the KITTI layout: the reference the bags must reproduce."""
    root = tmp_path_factory.mktemp("synth")
    synthesize(root, ["00"], seed=3, frames=6, scale=0.1, workers=1)
    return KittiSequence(root, "00")


def kitti_spec(kitti: KittiSequence, encoding: str, **changes) -> BagSpec:
    stamps_ns = [int(round(t * 1e9)) for t in kitti.times_s]
    spec = BagSpec(list(kitti.images()), stamps_ns, encoding, K=kitti.calibration.K0[:3, :3])
    for name, value in changes.items():
        setattr(spec, name, value)
    return spec


def small_spec(**changes) -> BagSpec:
    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 256, (12, 16), dtype=np.uint8) for _ in range(3)]
    K = np.array([[20.0, 0.0, 8.0], [0.0, 20.0, 6.0], [0.0, 0.0, 1.0]])
    spec = BagSpec(frames, [10**9, 2 * 10**9, 3 * 10**9], K=K, other_topics={"/imu": "imu"})
    for name, value in changes.items():
        setattr(spec, name, value)
    return spec


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("encoding", ["mono8", "rgb8", "bgr8", "png"])
def test_bag_frames_stamps_and_intrinsics_equal_the_kitti_folder(tmp_path, kitti, kind, encoding):
    bag = write_bag(tmp_path, kind, kitti_spec(kitti, encoding))
    source = open_bag_source(bag, TOPIC, camera_info_topic=INFO_TOPIC)
    assert source.name == "drive" and source.ground_truth is None and not source.is_synthetic
    assert source.frame_count == len(kitti) and source.image_size_hw == kitti.image_size_hw
    assert source.camera.intrinsics == CameraIntrinsics.from_matrix(kitti.calibration.K0)
    assert source.camera.distortion.is_none and source.camera.source == "camera_info"
    frames = list(source.frames())
    np.testing.assert_allclose([t for t, _ in frames], kitti.times_s, atol=1e-9)
    for (_, image), expected in zip(frames, kitti.images(), strict=True):
        assert image.dtype == np.uint8 and np.array_equal(image, expected)


@pytest.mark.parametrize("encoding", ["rgba8", "bgra8", "mono16", "8UC1"])
def test_other_lossless_encodings_decode_to_the_same_grey_frames(tmp_path, encoding):
    spec = small_spec(encoding=encoding)
    source = open_bag_source(write_bag(tmp_path, "mcap", spec), TOPIC, INFO_TOPIC)
    for (_, image), expected in zip(source.frames(), spec.frames, strict=True):
        assert np.array_equal(image, expected)


def test_given_intrinsics_are_used_and_frames_can_be_read_twice(tmp_path):
    bag = write_bag(tmp_path, "ros1", small_spec(K=None))
    intrinsics = CameraIntrinsics(30.0, 31.0, 7.5, 5.5)
    source = open_bag_source(bag, TOPIC, intrinsics=intrinsics)
    assert source.camera is None  # the given intrinsics describe it
    first, second = list(source.frames()), list(source.frames())
    assert len(first) == 3
    assert all(np.array_equal(a[1], b[1]) and a[0] == b[0] for a, b in zip(first, second, strict=True))
    np.testing.assert_allclose(source.timestamps_s, [1.0, 2.0, 3.0])


def test_name_is_the_bag_stem_made_safe_for_file_names(tmp_path):
    bag = write_bag(tmp_path, "ros2-sqlite3", small_spec(), stem="run 3.v2")
    assert open_bag_source(bag, TOPIC, INFO_TOPIC).name == "run_3_v2"


def test_raw_image_rows_with_padding_and_big_endian_mono16_decode():
    pixels = np.arange(12, dtype=np.uint8).reshape(3, 4)
    padded = np.zeros((3, 6), dtype=np.uint8)
    padded[:, :4] = pixels
    msg = SimpleNamespace(height=3, width=4, encoding="mono8", is_bigendian=0, step=6, data=padded.reshape(-1))
    assert np.array_equal(raw_image_to_grey(msg), pixels)
    wide = ((pixels.astype(np.uint16) << 8) | 0x7F).astype(">u2")  # low byte noise, dropped
    msg16 = SimpleNamespace(height=3, width=4, encoding="mono16", is_bigendian=1, step=8,
                            data=np.frombuffer(wide.tobytes(), dtype=np.uint8))
    assert np.array_equal(raw_image_to_grey(msg16), pixels)


def test_short_data_and_compressed_depth_are_refused():
    short = SimpleNamespace(height=3, width=4, encoding="mono8", is_bigendian=0, step=4, data=np.zeros(11, np.uint8))
    with pytest.raises(ImageMessageError, match="11 data bytes"):
        raw_image_to_grey(short)
    depth = SimpleNamespace(format="16UC1; compressedDepth png", data=np.zeros(4, np.uint8))
    with pytest.raises(ImageMessageError, match="depth"):
        compressed_image_to_grey(depth)


def test_rectified_topics_take_intrinsics_from_p_others_from_k():
    K = [100.0, 0, 50, 0, 100.0, 40, 0, 0, 1]
    P = [90.0, 0, 48, 0, 0, 90.0, 38, 0, 0, 0, 1, 0]
    msg = SimpleNamespace(k=K, p=P, width=100, height=80)
    assert is_rectified_topic("/cam/image_rect/compressed") and not is_rectified_topic("/cam/image_raw")
    assert camera_info_intrinsics(msg, True, (80, 100)) == CameraIntrinsics(90.0, 90.0, 48.0, 38.0)
    assert camera_info_intrinsics(msg, False, (80, 100)) == CameraIntrinsics(100.0, 100.0, 50.0, 40.0)
    ros1 = SimpleNamespace(K=K, P=P, width=0, height=0)  # ROS 1 names; size 0 = unset
    assert camera_info_intrinsics(ros1, False, (80, 100)).fx == 100.0
    with pytest.raises(CameraInfoError, match="100x80 images, the frames are 50x40"):
        camera_info_intrinsics(msg, False, (40, 50))


# ---------------------------------------------------------------- bad input: one-line errors naming the bag


def error_of(*args, **kwargs) -> str:
    with pytest.raises(FlowvoError) as caught:
        open_bag_source(*args, **kwargs)
    message = str(caught.value)
    assert "\n" not in message
    return message


def test_missing_path_file_of_another_kind_and_folder_without_metadata(tmp_path):
    assert "no such bag" in error_of(tmp_path / "absent.bag", TOPIC)
    (tmp_path / "notes.txt").write_text("hello")
    assert "not a ROS bag" in error_of(tmp_path / "notes.txt", TOPIC)
    assert "no metadata.yaml" in error_of(tmp_path, TOPIC)


def test_missing_topic_lists_the_image_topics(tmp_path):
    bag = write_bag(tmp_path, "ros1", small_spec())
    message = error_of(bag, "/camera/image_color", camera_info_topic=INFO_TOPIC)
    assert str(bag) in message and "/camera/image_color is not in the bag" in message
    assert "image topics: /camera/image_raw (Image)" in message and "/imu" not in message


def test_topic_of_the_wrong_type(tmp_path):
    bag = write_bag(tmp_path, "mcap", small_spec())
    assert "topic /imu has type sensor_msgs/msg/Imu" in error_of(bag, "/imu", INFO_TOPIC)
    assert "/imu has type sensor_msgs/msg/Imu, expected sensor_msgs/msg/CameraInfo" in error_of(bag, TOPIC, "/imu")
    missing = error_of(bag, TOPIC, "/camera/info")
    assert "/camera/info is not in the bag; CameraInfo topics: /camera/camera_info" in missing


def test_unsupported_encoding_names_the_topic_and_message(tmp_path):
    bag = write_bag(tmp_path, "ros2-mcap", small_spec(encoding="16UC1"))
    message = error_of(bag, TOPIC, INFO_TOPIC)
    assert str(bag) in message and "/camera/image_raw message 0: unsupported encoding '16UC1'" in message


@pytest.mark.parametrize("stamps_ns", [[10**9, 10**9, 3 * 10**9], [10**9, 3 * 10**9, 2 * 10**9]])
def test_non_increasing_header_stamps(tmp_path, stamps_ns):
    spec = small_spec(stamps_ns=stamps_ns, log_times_ns=[10**9, 2 * 10**9, 3 * 10**9])  # recorded in this order
    bag = write_bag(tmp_path, "ros1", spec)
    assert "header stamps must strictly increase" in error_of(bag, TOPIC, INFO_TOPIC)


def test_missing_intrinsics_lists_the_camera_info_topics(tmp_path):
    bag = write_bag(tmp_path, "ros2-sqlite3", small_spec())
    assert "CameraInfo topics in the bag: /camera/camera_info" in error_of(bag, TOPIC)
    assert "not both" in error_of(bag, TOPIC, INFO_TOPIC, CameraIntrinsics(1.0, 1.0, 1.0, 1.0))


def test_uncalibrated_or_mismatched_camera_info(tmp_path):
    zero = write_bag(tmp_path / "zero", "mcap", small_spec(K=np.zeros((3, 3))))
    assert "K is all zero" in error_of(zero, TOPIC, INFO_TOPIC)
    other = write_bag(tmp_path / "other", "mcap", small_spec(info_size_wh=(32, 24)))
    assert "CameraInfo is for 32x24 images, the frames are 16x12" in error_of(other, TOPIC, INFO_TOPIC)


def test_frames_of_different_sizes(tmp_path):
    spec = small_spec()
    spec.frames[2] = np.zeros((10, 16), dtype=np.uint8)
    bag = write_bag(tmp_path, "ros1", spec)
    assert "message 2 is 16x10, the first is 16x12" in error_of(bag, TOPIC, INFO_TOPIC)


@pytest.mark.parametrize("kind", KINDS)
def test_truncated_bag(tmp_path, kind):
    bag = write_bag(tmp_path, kind, small_spec())
    storage = next(p for p in bag.iterdir() if p.suffix in (".db3", ".mcap")) if bag.is_dir() else bag
    storage.write_bytes(storage.read_bytes()[: storage.stat().st_size * 2 // 3])
    assert "cannot read" in error_of(bag, TOPIC, INFO_TOPIC)


def test_corrupt_mcap_fails_with_a_flowvo_error(tmp_path):
    bag = write_bag(tmp_path, "mcap", small_spec())
    data = bytearray(bag.read_bytes())
    for index in range(len(data) // 3, len(data) // 3 + 200):
        data[index] ^= 0xFF
    bag.write_bytes(bytes(data))
    assert "cannot read" in error_of(bag, TOPIC, INFO_TOPIC)


def test_without_the_ros_extra_the_error_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setattr(extra, "find_spec", lambda name: None)
    assert "pip install 'flowvo[ros]'" in error_of(tmp_path / "x.bag", TOPIC)


def test_importing_the_ros_modules_does_not_import_rosbags_or_mcap():
    code = ("import sys, flowvo.sources.rosbag, flowvo.ros.odometry_mcap; "
            "assert not {'rosbags', 'mcap'} & set(sys.modules), sorted(sys.modules)")
    src = Path(__file__).resolve().parents[1] / "src"
    subprocess.run([sys.executable, "-c", code], check=True, env={"PYTHONPATH": str(src), "PATH": ""})



OPTICAL = (-0.5, 0.5, -0.5, 0.5)  # camera_link (x forward, z up) -> camera_optical (z forward, y down)
RIG = [("base_footprint", "base_link", (0.0, 0.0, 0.3), (0.0, 0.0, 0.0, 1.0)),
       ("base_link", "camera_link", (1.2, 0.1, 1.0), (0.0, 0.0, 0.0, 1.0)),
       ("camera_link", "camera_optical", (0.0, 0.0, 0.0), OPTICAL)]


NOSE_DOWN_7 = (0.0, float(np.sin(np.radians(3.5))), 0.0, float(np.cos(np.radians(3.5))))  # about y: x tilts down
RIGHT_DOWN_5 = (float(np.sin(np.radians(2.5))), 0.0, 0.0, float(np.cos(np.radians(2.5))))  # about x (forward): y (left)
# tilts up


@pytest.mark.parametrize("kind", ["ros2-sqlite3", "mcap"])
def test_camera_height_pitch_and_roll_come_from_tf_static(tmp_path, kind):
    bag = write_bag(tmp_path, kind, small_spec(tf_static=RIG))
    level = open_bag_source(bag, TOPIC, INFO_TOPIC)
    assert level.camera_height_m == pytest.approx(1.3) and level.camera_pitch_deg == pytest.approx(0.0, abs=1e-9)
    assert level.camera_roll_deg == pytest.approx(0.0, abs=1e-9)
    pitched_rig = [RIG[0], RIG[1][:3] + (NOSE_DOWN_7,), RIG[2]]
    pitched = open_bag_source(write_bag(tmp_path / "pitched", kind, small_spec(tf_static=pitched_rig)), TOPIC,
                              INFO_TOPIC)
    assert pitched.camera_pitch_deg == pytest.approx(7.0, abs=1e-6)
    assert pitched.camera_roll_deg == pytest.approx(0.0, abs=1e-9)
    rolled_rig = [RIG[0], RIG[1][:3] + (RIGHT_DOWN_5,), RIG[2]]
    rolled = open_bag_source(write_bag(tmp_path / "rolled", kind, small_spec(tf_static=rolled_rig)), TOPIC,
                             INFO_TOPIC)
    assert rolled.camera_pitch_deg == pytest.approx(0.0, abs=1e-9)
    assert rolled.camera_roll_deg == pytest.approx(5.0, abs=1e-6)
    unconnected = write_bag(tmp_path / "other", kind, small_spec(tf_static=RIG[:1]))
    source = open_bag_source(unconnected, TOPIC, INFO_TOPIC)
    assert source.camera_height_m is None and source.camera_pitch_deg is None and source.camera_roll_deg is None


def test_tf_height_follows_the_chain_of_rotations():
    from flowvo.ros.tf_static import StaticTransform, camera_height_m

    tilted = [StaticTransform("base_footprint", "mast", (0.0, 0.0, 2.0), (0.0, 0.7071068, 0.0, 0.7071068)),
              StaticTransform("mast", "camera_optical", (0.5, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))]
    assert camera_height_m(tilted, "camera_optical") == pytest.approx(1.5)  # the mast's x points down
    assert camera_height_m(tilted, "nowhere") is None
