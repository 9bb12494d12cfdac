"""Write small ROS bags for tests: a ROS 1 .bag, a ROS 2 folder (sqlite3 or mcap) or a bare .mcap file.

Frames are grey uint8 images; each is stored as sensor_msgs/Image (mono8, rgb8, bgr8, ...) or as a png
sensor_msgs/CompressedImage, optionally with a sensor_msgs/CameraInfo message per frame.
"""

from __future__ import annotations

import shutil
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.typesys import Stores, get_typestore

KINDS = ("ros1", "ros2-sqlite3", "ros2-mcap", "mcap")
_COLOUR = {"rgb8": cv2.COLOR_GRAY2RGB, "bgr8": cv2.COLOR_GRAY2BGR, "rgba8": cv2.COLOR_GRAY2RGBA,
           "bgra8": cv2.COLOR_GRAY2BGRA}


@dataclass
class BagSpec:
    """What to write: frames (grey uint8) with their header stamps (ns), how to encode them, and extras."""

    frames: Sequence[np.ndarray]
    stamps_ns: Sequence[int]
    encoding: str = "mono8"  # an Image encoding, or "png" for a CompressedImage
    image_topic: str = "/camera/image_raw"
    K: np.ndarray | None = None  # writes a CameraInfo per frame when given
    info_topic: str = "/camera/camera_info"
    info_size_wh: tuple[int, int] | None = None  # CameraInfo width, height (default: the frames' size)
    other_topics: dict[str, str] = field(default_factory=dict)  # topic -> "imu": one sensor_msgs/Imu message
    log_times_ns: Sequence[int] | None = None  # when the bag recorded each frame (default: its header stamp)
    # (parent, child, translation xyz m, rotation xyzw) written as one tf2_msgs/TFMessage on /tf_static
    tf_static: Sequence[tuple[str, str, tuple, tuple]] = ()


def bag_path(folder: Path, kind: str, stem: str = "drive") -> Path:
    """Where ``write_bag`` puts a bag of ``kind`` named ``stem`` inside ``folder``."""
    return folder / {"ros1": f"{stem}.bag", "mcap": f"{stem}.mcap"}.get(kind, stem)


def write_bag(folder: Path, kind: str, spec: BagSpec, stem: str = "drive") -> Path:
    """Write ``spec`` as a bag of ``kind`` (one of KINDS) in ``folder``; returns its path."""
    path = bag_path(folder, kind, stem)
    ros1 = kind == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if ros1:
        writer = Ros1Writer(path)
    else:
        plugin = StoragePlugin.SQLITE3 if kind == "ros2-sqlite3" else StoragePlugin.MCAP
        writer = Ros2Writer(folder / f"{stem}.tmpbag" if kind == "mcap" else path, version=9, storage_plugin=plugin)
    image_type = "sensor_msgs/msg/CompressedImage" if spec.encoding == "png" else "sensor_msgs/msg/Image"
    with writer:
        image_conn = writer.add_connection(spec.image_topic, image_type, typestore=store)
        info_conn = (writer.add_connection(spec.info_topic, "sensor_msgs/msg/CameraInfo", typestore=store)
                     if spec.K is not None else None)
        for topic in spec.other_topics:
            conn = writer.add_connection(topic, "sensor_msgs/msg/Imu", typestore=store)
            writer.write(conn, int(spec.stamps_ns[0]), _serialize(store, ros1, _imu(store, ros1, spec.stamps_ns[0])))
        if spec.tf_static:
            conn = writer.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=store)
            writer.write(conn, int(spec.stamps_ns[0]), _serialize(store, ros1, _tf(store, ros1, spec)))
        log_times_ns = spec.log_times_ns or spec.stamps_ns
        for frame, stamp_ns, log_ns in zip(spec.frames, spec.stamps_ns, log_times_ns, strict=True):
            message = _image(store, ros1, spec.encoding, frame, stamp_ns)
            writer.write(image_conn, int(log_ns), _serialize(store, ros1, message))
            if info_conn is not None:
                info = _camera_info(store, ros1, spec.K, spec.info_size_wh or frame.shape[::-1], stamp_ns)
                writer.write(info_conn, int(log_ns), _serialize(store, ros1, info))
    if kind == "mcap":
        tmp = folder / f"{stem}.tmpbag"
        (tmp / f"{tmp.name}.mcap").rename(path)
        shutil.rmtree(tmp)
    return path


def _serialize(store, ros1: bool, message) -> bytes:
    msgtype = message.__msgtype__
    return bytes(store.serialize_ros1(message, msgtype) if ros1 else store.serialize_cdr(message, msgtype))


def _header(store, ros1: bool, stamp_ns: int, frame_id: str = "camera_optical"):
    Header, Time = store.types["std_msgs/msg/Header"], store.types["builtin_interfaces/msg/Time"]
    stamp = Time(sec=int(stamp_ns) // 10**9, nanosec=int(stamp_ns) % 10**9)
    return Header(seq=0, stamp=stamp, frame_id=frame_id) if ros1 else Header(stamp=stamp, frame_id=frame_id)


def _image(store, ros1: bool, encoding: str, frame: np.ndarray, stamp_ns: int):
    header = _header(store, ros1, stamp_ns)
    if encoding == "png":
        ok, data = cv2.imencode(".png", frame)
        assert ok
        return store.types["sensor_msgs/msg/CompressedImage"](header=header, format="mono8; png compressed ",
                                                              data=data.reshape(-1))
    if encoding == "mono16":
        pixels = frame.astype("<u2") * 257  # high byte == the grey value
    else:
        pixels = cv2.cvtColor(frame, _COLOUR[encoding]) if encoding in _COLOUR else frame
    h, w = frame.shape
    data = np.frombuffer(np.ascontiguousarray(pixels).tobytes(), dtype=np.uint8)
    return store.types["sensor_msgs/msg/Image"](header=header, height=h, width=w, encoding=encoding,
                                                is_bigendian=0, step=len(data) // h, data=data)


def _camera_info(store, ros1: bool, K: np.ndarray, size_wh: tuple[int, int], stamp_ns: int):
    P = np.hstack([K, np.zeros((3, 1))])
    matrices = {"D": np.zeros(5), "K": K.reshape(-1), "R": np.eye(3).reshape(-1), "P": P.reshape(-1)}
    if not ros1:
        matrices = {name.lower(): value for name, value in matrices.items()}
    roi = store.types["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    return store.types["sensor_msgs/msg/CameraInfo"](
        header=_header(store, ros1, stamp_ns), height=size_wh[1], width=size_wh[0], distortion_model="plumb_bob",
        binning_x=0, binning_y=0, roi=roi, **{name: value.astype(np.float64) for name, value in matrices.items()})


def _imu(store, ros1: bool, stamp_ns: int):
    Quaternion, Vector3 = store.types["geometry_msgs/msg/Quaternion"], store.types["geometry_msgs/msg/Vector3"]
    zeros = np.zeros(9)
    return store.types["sensor_msgs/msg/Imu"](
        header=_header(store, ros1, stamp_ns, "imu"), orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=zeros, angular_velocity=Vector3(x=0.0, y=0.0, z=0.0),
        angular_velocity_covariance=zeros, linear_acceleration=Vector3(x=0.0, y=0.0, z=0.0),
        linear_acceleration_covariance=zeros)


def _tf(store, ros1: bool, spec: BagSpec):
    types = store.types
    transforms = [types["geometry_msgs/msg/TransformStamped"](
        header=_header(store, ros1, spec.stamps_ns[0], parent), child_frame_id=child,
        transform=types["geometry_msgs/msg/Transform"](translation=types["geometry_msgs/msg/Vector3"](*xyz),
                                                       rotation=types["geometry_msgs/msg/Quaternion"](*xyzw)))
        for parent, child, xyz, xyzw in spec.tf_static]
    return types["tf2_msgs/msg/TFMessage"](transforms=transforms)
