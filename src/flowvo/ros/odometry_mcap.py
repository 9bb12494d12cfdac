"""Write a trajectory as a ROS 2 MCAP file: nav_msgs/Odometry, tf2_msgs/TFMessage and nav_msgs/Path.

Messages are CDR-serialized ROS 2 (Humble) types with their ``ros2msg`` schemas embedded, in an indexed,
uncompressed MCAP with the ``ros2`` profile, written by rosbags' rosbag2 MCAP storage (the ``.mcap`` of a
ROS 2 bag folder, without its metadata.yaml), the layout Foxglove, Rerun and ``ros2 bag play`` read; the
tests read it back with rosbags and with the mcap library. Frames: ``flowvo.ros.frames`` (parent ``odom``,
forward-left-up at the first camera; child ``camera_optical``).

Per frame, stamped with the image's stamp (header stamp = MCAP log and publish time):
- ``odometry_topic`` (nav_msgs/Odometry): pose of the child in the parent frame; twist of the child in the
  child frame, as ROS defines it (``flowvo.ros.frames.camera_twists``); with their covariances when given
  (:mod:`flowvo.odometry.covariance`: the twist's in the child frame, the pose's along the parent's axes),
  else zero.
- ``tf_topic`` (tf2_msgs/TFMessage): the same transform, parent -> child.
Once, at the first frame's stamp, with the whole trajectory (one PoseStamped per frame with its own stamp):
- ``path_topic`` (nav_msgs/Path), offered with transient-local (latched) QoS, so viewers show the full path
  from the start of playback and late subscribers of ``ros2 bag play`` still receive it.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from flowvo.errors import FlowvoError
from flowvo.io.atomic import atomic_path
from flowvo.kitti.poses import rotation_to_quaternion_xyzw
from flowvo.ros.extra import require_ros_extra
from flowvo.ros.frames import camera_twist_covariances, camera_twists, odom_pose_covariances, odom_poses

DEFAULT_FRAME_ID = "odom"
DEFAULT_CHILD_FRAME_ID = "camera_optical"
DEFAULT_ODOMETRY_TOPIC = "/flowvo/odom"
DEFAULT_TF_TOPIC = "/tf"
DEFAULT_PATH_TOPIC = "/flowvo/path"


def write_odometry_mcap(path: str | Path, timestamps_s: np.ndarray, T_world_cam: np.ndarray,
                        frame_id: str = DEFAULT_FRAME_ID, child_frame_id: str = DEFAULT_CHILD_FRAME_ID,
                        odometry_topic: str = DEFAULT_ODOMETRY_TOPIC, tf_topic: str = DEFAULT_TF_TOPIC,
                        path_topic: str = DEFAULT_PATH_TOPIC, exact_stamps_ns: np.ndarray | None = None,
                        covariances: tuple[np.ndarray, np.ndarray] | None = None) -> Path:
    """Write the camera poses ``T_world_cam`` (N, 4, 4; flowvo's optical world frame, metres) stamped with
    ``timestamps_s`` (N,; seconds, non-negative, strictly increasing; rounded to nanoseconds), or with
    ``exact_stamps_ns`` (N,) when given (the images' own integer stamps), to the MCAP file ``path``,
    atomically (a temporary file renamed into place); returns ``path``. ``covariances``: the steps' (N - 1,
    6, 6) and the poses' (N, 6, 6), each in its camera's frame (:mod:`flowvo.odometry.covariance`); without
    them the messages' covariances are zero.

    Raises ValueError for arrays of the wrong shape or stamps out of order, and FlowvoError for frame ids
    that tf2 refuses (empty, leading '/', parent == child) and topics that are not absolute ROS names.
    """
    require_ros_extra("writing MCAP odometry")
    stamps_ns = _stamps_ns(timestamps_s, T_world_cam)
    if exact_stamps_ns is not None:  # float seconds since 1970 lose up to ~120 ns: ROS exact-time sync needs these
        stamps_ns = [int(ns) for ns in exact_stamps_ns]
    check_names(frame_id, child_frame_id, (odometry_topic, tf_topic, path_topic))
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    messages = _Messages(store, frame_id, child_frame_id)
    T_odom_cam = odom_poses(T_world_cam)
    linear_mps, angular_radps = camera_twists(timestamps_s, T_world_cam)
    if covariances is None:
        pose_covariance = twist_covariance = np.zeros((len(T_world_cam), 6, 6))
    else:
        pose_covariance = odom_pose_covariances(T_world_cam, covariances[1])
        twist_covariance = camera_twist_covariances(timestamps_s, covariances[0])
    target = Path(path)
    with atomic_path(target) as tmp_file, tempfile.TemporaryDirectory(prefix=f".{target.stem}.",
                                                                      dir=target.parent) as tmp_dir:
        bag = Path(tmp_dir) / "bag"
        with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
            path_conn = writer.add_connection(path_topic, "nav_msgs/msg/Path", typestore=store,
                                              offered_qos_profiles=[_qos(depth=1, latched=True)])
            odometry_conn = writer.add_connection(odometry_topic, "nav_msgs/msg/Odometry", typestore=store,
                                                  offered_qos_profiles=[_qos(depth=10, latched=False)])
            tf_conn = writer.add_connection(tf_topic, "tf2_msgs/msg/TFMessage", typestore=store,
                                            offered_qos_profiles=[_qos(depth=100, latched=False)])
            writer.write(path_conn, stamps_ns[0], messages.serialize(messages.path(stamps_ns, T_odom_cam)))
            for stamp_ns, pose, linear, angular, pose_cov, twist_cov in zip(
                    stamps_ns, T_odom_cam, linear_mps, angular_radps, pose_covariance, twist_covariance, strict=True):
                writer.write(odometry_conn, stamp_ns, messages.serialize(
                    messages.odometry(stamp_ns, pose, linear, angular, pose_cov, twist_cov)))
                writer.write(tf_conn, stamp_ns, messages.serialize(messages.tf(stamp_ns, pose)))
        os.replace(bag / "bag.mcap", tmp_file)
    return target


MAX_STAMP_S = 2**31 - 1  # ROS 2 builtin_interfaces/Time holds seconds in an int32 (to January 2038)


def check_stamps(timestamps_s: np.ndarray, where: str | Path) -> None:
    """Refuse stamps an MCAP cannot carry: not finite, negative, past ``MAX_STAMP_S`` or not increasing
    (a :class:`FlowvoError` naming ``where``, the drive; called before any output is written)."""
    stamps = np.asarray(timestamps_s, dtype=np.float64)
    bad = ~np.isfinite(stamps) | (stamps < 0) | (stamps > MAX_STAMP_S)
    if bad.any():
        index = int(np.argmax(bad))
        raise FlowvoError(f"frame {index} is stamped {stamps[index]:g} s; MCAP odometry needs stamps in "
                          f"[0, {MAX_STAMP_S}] s (ROS time): fix the timestamps or leave out --mcap", where)
    if np.any(np.diff(stamps) <= 0):
        raise FlowvoError("timestamps must strictly increase for MCAP odometry", where)


def _stamps_ns(timestamps_s: np.ndarray, T_world_cam: np.ndarray) -> list[int]:
    """Stamps in integer nanoseconds after checking shapes and order."""
    stamps = np.asarray(timestamps_s, dtype=np.float64)
    poses = np.asarray(T_world_cam)
    if poses.ndim != 3 or poses.shape[1:] != (4, 4) or len(poses) == 0:
        raise ValueError(f"T_world_cam must be (N, 4, 4) with N >= 1, got {poses.shape}")
    if stamps.shape != (len(poses),):
        raise ValueError(f"timestamps_s must have one stamp per pose, got {stamps.shape} for {len(poses)} poses")
    if not np.all(np.isfinite(stamps)) or stamps[0] < 0 or np.any(np.diff(stamps) <= 0):
        raise ValueError("timestamps_s must be finite, non-negative and strictly increasing")
    check_stamps(stamps, "timestamps_s")
    return [int(ns) for ns in np.round(stamps * 1e9).astype(np.int64)]


def check_names(frame_id: str, child_frame_id: str,
                topics: tuple[str, ...] = (DEFAULT_ODOMETRY_TOPIC, DEFAULT_TF_TOPIC, DEFAULT_PATH_TOPIC)) -> None:
    """Refuse frame ids tf2 refuses (empty, leading '/', parent == child) and topics that are not distinct
    absolute ROS names (callers check before a long run, so nothing is computed for nothing)."""
    for name in (frame_id, child_frame_id):
        if not name or name.startswith("/"):
            raise FlowvoError(f"frame id {name!r} must be non-empty without a leading '/' (tf2 refuses it)")
    if frame_id == child_frame_id:
        raise FlowvoError(f"the parent and child frame ids are both {frame_id!r}")
    for topic in topics:
        if not topic.startswith("/") or len(topic) < 2:
            raise FlowvoError(f"topic {topic!r} must be an absolute ROS name such as /flowvo/odom")
    if len(set(topics)) != len(topics):
        raise FlowvoError(f"the odometry, tf and path topics must differ, got {', '.join(topics)}")


def _qos(depth: int, latched: bool) -> Any:
    """A reliable keep-last QoS profile of ``depth``, transient-local (latched) or volatile."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    infinite = QosTime(sec=2147483647, nsec=4294967295)  # rmw's "infinite" duration
    return Qos(history=QosHistory.KEEP_LAST, depth=depth, reliability=QosReliability.RELIABLE,
               durability=QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE,
               deadline=infinite, lifespan=infinite, liveliness=QosLiveliness.AUTOMATIC,
               liveliness_lease_duration=infinite, avoid_ros_namespace_conventions=False)


class _Messages:
    """Builds the ROS 2 messages of one trajectory from a rosbags typestore."""

    def __init__(self, store: Any, frame_id: str, child_frame_id: str) -> None:
        self.store = store
        self.types = store.types
        self.frame_id = frame_id
        self.child_frame_id = child_frame_id

    def serialize(self, message: Any) -> bytes:
        return bytes(self.store.serialize_cdr(message, message.__msgtype__))

    def header(self, stamp_ns: int) -> Any:
        stamp = self.types["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
        return self.types["std_msgs/msg/Header"](stamp=stamp, frame_id=self.frame_id)

    def vector3(self, xyz: np.ndarray, type_name: str = "geometry_msgs/msg/Vector3") -> Any:
        return self.types[type_name](x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2]))

    def quaternion(self, rotation: np.ndarray) -> Any:
        x, y, z, w = (float(v) for v in rotation_to_quaternion_xyzw(rotation))
        return self.types["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)

    def pose(self, T: np.ndarray) -> Any:
        return self.types["geometry_msgs/msg/Pose"](position=self.vector3(T[:3, 3], "geometry_msgs/msg/Point"),
                                                    orientation=self.quaternion(T[:3, :3]))

    def odometry(self, stamp_ns: int, T: np.ndarray, linear_mps: np.ndarray, angular_radps: np.ndarray,
                 pose_covariance: np.ndarray, twist_covariance: np.ndarray) -> Any:
        t = self.types
        twist = t["geometry_msgs/msg/Twist"](linear=self.vector3(linear_mps), angular=self.vector3(angular_radps))
        return t["nav_msgs/msg/Odometry"](
            header=self.header(stamp_ns), child_frame_id=self.child_frame_id,
            pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=self.pose(T), covariance=pose_covariance.ravel()),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=twist_covariance.ravel()))

    def tf(self, stamp_ns: int, T: np.ndarray) -> Any:
        t = self.types
        transform = t["geometry_msgs/msg/Transform"](translation=self.vector3(T[:3, 3]),
                                                     rotation=self.quaternion(T[:3, :3]))
        stamped = t["geometry_msgs/msg/TransformStamped"](header=self.header(stamp_ns),
                                                          child_frame_id=self.child_frame_id, transform=transform)
        return t["tf2_msgs/msg/TFMessage"](transforms=[stamped])

    def path(self, stamps_ns: list[int], T_odom_cam: np.ndarray) -> Any:
        poses = [self.types["geometry_msgs/msg/PoseStamped"](header=self.header(stamp_ns), pose=self.pose(T))
                 for stamp_ns, T in zip(stamps_ns, T_odom_cam, strict=True)]
        return self.types["nav_msgs/msg/Path"](header=self.header(stamps_ns[0]), poses=poses)

