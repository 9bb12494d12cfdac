"""Odometry MCAP output: ROS frame conventions, twist, and a file that rosbags and the mcap reader both read."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from flowvo.errors import FlowvoError
from flowvo.geometry import chain_se3, so3_exp
from flowvo.kitti.poses import rotation_to_quaternion_xyzw
from flowvo.ros.frames import R_FLU_OPTICAL, camera_twists, odom_poses

pytest.importorskip("rosbags")
pytest.importorskip("mcap")

from ros_bags import BagSpec, write_bag  # noqa: E402

from flowvo.camera import CameraIntrinsics  # noqa: E402
from flowvo.ros import odometry_mcap  # noqa: E402
from flowvo.ros.odometry_mcap import write_odometry_mcap  # noqa: E402
from flowvo.sources.rosbag import open_bag_source  # noqa: E402

DT_S = 0.1
START_S = 1_700_000_000.0


def constant_motion(count: int, forward_m: float = 1.0, yaw_rad: float = 0.05) -> np.ndarray:
    """Poses T_world_cam (count, 4, 4) of a camera moving forward (+z) while turning right (about +y)."""
    motion = np.eye(4)
    motion[:3, :3] = so3_exp(np.array([0.0, yaw_rad, 0.0]))
    motion[:3, 3] = [0.0, 0.0, forward_m]
    return chain_se3(np.repeat(motion[None], count - 1, axis=0))


def stamps_s(count: int) -> np.ndarray:
    return START_S + DT_S * np.arange(count)


def test_odom_frame_is_forward_left_up_at_the_first_camera():
    T = constant_motion(3)
    T_odom_cam = odom_poses(T)
    np.testing.assert_allclose(rotation_to_quaternion_xyzw(T_odom_cam[0, :3, :3]), [-0.5, 0.5, -0.5, 0.5])
    np.testing.assert_allclose(T_odom_cam[1, :3, 3], [1.0, 0.0, 0.0], atol=1e-12)  # 1 m forward = +x in odom
    assert T_odom_cam[2, 1, 3] < 0  # turning right drifts to -y (right) in odom
    np.testing.assert_allclose(R_FLU_OPTICAL @ np.array([1.0, 0.0, 0.0]), [0.0, -1.0, 0.0])  # right = -left


def test_twist_is_in_the_camera_frame_and_frame_zero_takes_the_first_motion():
    linear, angular = camera_twists(DT_S * np.arange(5), constant_motion(5, forward_m=1.0, yaw_rad=0.05))
    expected_linear = so3_exp(np.array([0.0, 0.05, 0.0])).T @ np.array([0.0, 0.0, 1.0]) / DT_S
    np.testing.assert_allclose(linear, np.tile(expected_linear, (5, 1)), atol=1e-6)
    np.testing.assert_allclose(angular, np.tile([0.0, 0.5, 0.0], (5, 1)), atol=1e-6)
    still_linear, still_angular = camera_twists(stamps_s(1), np.eye(4)[None])
    assert still_linear.shape == (1, 3) and not still_linear.any() and not still_angular.any()


def read_with_rosbags(path: Path) -> dict[str, list[tuple[int, object]]]:
    from rosbags.highlevel import AnyReader

    by_topic: dict[str, list[tuple[int, object]]] = {}
    with AnyReader([path]) as reader:
        for connection, log_ns, raw in reader.messages():
            by_topic.setdefault(connection.topic, []).append((log_ns, reader.deserialize(raw, connection.msgtype)))
    return by_topic


def position(pose) -> np.ndarray:
    return np.array([pose.position.x, pose.position.y, pose.position.z])


def test_mcap_reads_back_through_rosbags_with_stamps_frames_and_poses(tmp_path):
    T, stamps = constant_motion(6), stamps_s(6)
    out = write_odometry_mcap(tmp_path / "out" / "drive.mcap", stamps, T)
    assert out == tmp_path / "out" / "drive.mcap" and [p.name for p in out.parent.iterdir()] == ["drive.mcap"]
    topics = read_with_rosbags(out)
    assert {name: len(messages) for name, messages in topics.items()} == {"/flowvo/path": 1, "/flowvo/odom": 6,
                                                                          "/tf": 6}
    stamps_ns = np.round(stamps * 1e9).astype(np.int64)
    expected = odom_poses(T)
    linear, _ = camera_twists(stamps, T)
    for index, ((log_ns, odom), (_, tf)) in enumerate(zip(topics["/flowvo/odom"], topics["/tf"], strict=True)):
        assert log_ns == stamps_ns[index] == odom.header.stamp.sec * 10**9 + odom.header.stamp.nanosec
        assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "camera_optical")
        np.testing.assert_allclose(position(odom.pose.pose), expected[index, :3, 3], atol=1e-12)
        twist = odom.twist.twist.linear
        np.testing.assert_allclose([twist.x, twist.y, twist.z], linear[index])
        (transform,) = tf.transforms
        assert transform.header.stamp == odom.header.stamp and transform.child_frame_id == "camera_optical"
        q = transform.transform.rotation
        np.testing.assert_allclose([q.x, q.y, q.z, q.w], rotation_to_quaternion_xyzw(expected[index, :3, :3]))
    ((path_log_ns, path),) = topics["/flowvo/path"]
    assert path_log_ns == stamps_ns[0] and path.header.frame_id == "odom" and len(path.poses) == 6
    np.testing.assert_allclose(position(path.poses[-1].pose), expected[-1, :3, 3], atol=1e-12)
    assert path.poses[-1].header.stamp == topics["/flowvo/odom"][-1][1].header.stamp


def test_mcap_carries_the_covariances_twist_per_second_in_the_camera_pose_along_odom(tmp_path):
    T, stamps = constant_motion(4, yaw_rad=0.0), stamps_s(4)
    steps = np.zeros((3, 6, 6))
    steps[:, 2, 2] = 0.01  # forward (camera z): 0.1 m a step
    steps[:, 4, 4] = 1e-6  # about the camera's y axis (down)
    poses = np.zeros((4, 6, 6))
    poses[1:, 2, 2] = [0.01, 0.02, 0.03]
    messages = [odom for _, odom in read_with_rosbags(write_odometry_mcap(
        tmp_path / "c.mcap", stamps, T, covariances=(steps, poses)))["/flowvo/odom"]]
    twist = [np.array(m.twist.covariance).reshape(6, 6) for m in messages]
    pose = [np.array(m.pose.covariance).reshape(6, 6) for m in messages]
    for index in range(4):  # frame 0 takes the first step's twist, as its velocity does
        np.testing.assert_allclose(twist[index], steps[max(index - 1, 0)] / DT_S**2, rtol=1e-5)  # stamps in 1.7e9 s
    assert not pose[0].any()
    np.testing.assert_allclose(np.diag(pose[3]), [0.03, 0.0, 0.0, 0.0, 0.0, 0.0], atol=1e-15)  # forward is odom x
    without = read_with_rosbags(write_odometry_mcap(tmp_path / "z.mcap", stamps, T))["/flowvo/odom"]
    assert not any(np.any(odom.pose.covariance) or np.any(odom.twist.covariance) for _, odom in without)


def test_mcap_reads_with_the_mcap_library_and_its_embedded_ros2_schemas(tmp_path):
    from mcap.reader import make_reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    out = write_odometry_mcap(tmp_path / "a.mcap", stamps_s(4), constant_motion(4), frame_id="map",
                              child_frame_id="flowvo_camera_optical", odometry_topic="/vo/odom",
                              tf_topic="/vo/tf", path_topic="/vo/path")
    store = get_typestore(Stores.EMPTY)  # decode with nothing but the file's own message definitions
    with open(out, "rb") as handle:
        reader = make_reader(handle)
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary.statistics.message_count == 9
        channels = {channel.topic: channel for channel in summary.channels.values()}
        assert set(channels) == {"/vo/odom", "/vo/tf", "/vo/path"}
        assert "transient_local" in channels["/vo/path"].metadata["offered_qos_profiles"]
        assert "volatile" in channels["/vo/odom"].metadata["offered_qos_profiles"]
        for schema in summary.schemas.values():
            assert schema.encoding == "ros2msg"
            store.register(get_types_from_msg(schema.data.decode(), schema.name))
        odometry = [store.deserialize_cdr(message.data, schema.name)
                    for schema, channel, message in reader.iter_messages(topics=["/vo/odom"])]
    assert all(channel.message_encoding == "cdr" for channel in channels.values())
    assert [o.header.frame_id for o in odometry] == ["map"] * 4
    assert odometry[0].child_frame_id == "flowvo_camera_optical"
    np.testing.assert_allclose(position(odometry[3].pose.pose), odom_poses(constant_motion(4))[3, :3, 3], atol=1e-12)


def test_bag_in_mcap_out_keeps_the_image_stamps(tmp_path):
    frames = [np.full((8, 10), value, dtype=np.uint8) for value in (10, 20, 30)]
    stamps_ns = [1_700_000_000_000_000_000 + k * 33_333_333 for k in range(3)]  # 30 Hz since 1970
    bag = write_bag(tmp_path, "ros1", BagSpec(frames, stamps_ns))
    source = open_bag_source(bag, "/camera/image_raw", intrinsics=CameraIntrinsics(10.0, 10.0, 5.0, 4.0))
    rounded = write_odometry_mcap(tmp_path / "rounded.mcap", source.timestamps_s, constant_motion(3))
    logged = [log_ns for log_ns, _ in read_with_rosbags(rounded)["/flowvo/odom"]]
    assert np.all(np.abs(np.array(logged) - stamps_ns) <= 120)  # float64 seconds since 1970: 0.24 us resolution
    exact = write_odometry_mcap(tmp_path / "vo.mcap", source.timestamps_s, constant_motion(3),
                                exact_stamps_ns=source.stamps_ns)
    assert [log_ns for log_ns, _ in read_with_rosbags(exact)["/flowvo/odom"]] == stamps_ns  # exact-time sync


def test_existing_output_survives_a_failed_write_and_no_temporary_files_remain(tmp_path, monkeypatch):
    out = write_odometry_mcap(tmp_path / "vo.mcap", stamps_s(3), constant_motion(3))
    before = out.read_bytes()

    def fail(*args):
        raise RuntimeError("disk full")

    monkeypatch.setattr(odometry_mcap._Messages, "tf", fail)
    with pytest.raises(RuntimeError, match="disk full"):
        write_odometry_mcap(out, stamps_s(5), constant_motion(5))
    assert out.read_bytes() == before and [p.name for p in tmp_path.iterdir()] == ["vo.mcap"]


@pytest.mark.parametrize("names, match", [
    ({"frame_id": "/odom"}, "leading '/'"),
    ({"child_frame_id": ""}, "non-empty"),
    ({"child_frame_id": "odom"}, "both 'odom'"),
    ({"odometry_topic": "odom"}, "absolute ROS name"),
    ({"path_topic": "/tf"}, "must differ"),
])
def test_bad_frame_ids_and_topics_are_refused_before_writing(tmp_path, names, match):
    with pytest.raises(FlowvoError, match=match):
        write_odometry_mcap(tmp_path / "vo.mcap", stamps_s(2), constant_motion(2), **names)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("stamps, poses, match", [
    (np.array([0.0, 0.1]), np.eye(4)[None].repeat(3, 0), "one stamp per pose"),
    (np.array([0.2, 0.1]), np.eye(4)[None].repeat(2, 0), "strictly increasing"),
    (np.array([-1.0, 0.1]), np.eye(4)[None].repeat(2, 0), "non-negative"),
    (np.array([]), np.zeros((0, 4, 4)), "N >= 1"),
])
def test_stamps_and_poses_must_match_and_increase(tmp_path, stamps, poses, match):
    with pytest.raises(ValueError, match=match):
        write_odometry_mcap(tmp_path / "vo.mcap", stamps, poses)
    assert not any(tmp_path.iterdir())
