"""Frames of one image topic of a ROS bag: a ROS 1 ``.bag``, a ROS 2 bag folder, or a bare ``.mcap``/``.db3``.

``open_bag_source`` validates everything it can before any output exists: the bag opens, the topic exists
and carries sensor_msgs/Image or CompressedImage, every header stamp strictly increases, every raw image has a
supported encoding and the same size, and intrinsics are known (from a CameraInfo topic or given). It reads the
topic once to do so, without decoding pixels; ``frames()`` then reads it again, one message at a time, so
a bag never has to fit in memory. Image decoding rules: ``flowvo.ros.images``; CameraInfo: ``flowvo.ros.camera_info``.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import closing, contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from flowvo.camera import Camera, CameraIntrinsics
from flowvo.errors import FlowvoError
from flowvo.ros.camera_info import (
    CAMERA_INFO_TYPE,
    CameraInfoError,
    camera_info_distortion,
    camera_info_intrinsics,
    is_rectified_topic,
)
from flowvo.ros.extra import require_ros_extra
from flowvo.ros.images import (
    IMAGE_TYPE,
    IMAGE_TYPES,
    ImageMessageError,
    compressed_image_to_grey,
    image_message_to_grey,
    raw_image_size_hw,
)
from flowvo.ros.tf_static import StaticTransform, camera_height_m, camera_mounting_deg
from flowvo.sources.base import safe_source_name
from flowvo.trajectory import MIN_FRAME_INTERVAL_S, Trajectory

BAG_FILE_SUFFIXES = (".bag", ".mcap", ".db3")
TF_STATIC_TOPIC = "/tf_static"
TF_MESSAGE_TYPE = "tf2_msgs/msg/TFMessage"
# What repairs a recording cut short (no index or summary at the end of the file).
_REPAIR_HINTS = {".bag": "; if the recording was cut short, `rosbag reindex` may repair it",
                 ".mcap": "; if the recording was cut short, `mcap recover` may repair it"}


class BagSource:
    """A FrameSource over the images of ``topic`` in the bag at ``path`` (build it with ``open_bag_source``).

    ``timestamps_s`` (N,): the images' header stamps in seconds (float64: sub-microsecond rounding for
    stamps since 1970), strictly increasing. ``message_type``: sensor_msgs/msg/Image or CompressedImage.
    """

    ground_truth: Trajectory | None = None
    is_synthetic: bool = False

    def __init__(self, path: Path, topic: str, message_type: str, name: str, camera: Camera | None,
                 image_size_hw: tuple[int, int], stamps_ns: np.ndarray, camera_height_m: float | None = None,
                 camera_pitch_deg: float | None = None, camera_roll_deg: float | None = None) -> None:
        self.path = path
        self.camera_height_m = camera_height_m  # from /tf_static, when the bag has it
        self.camera_pitch_deg = camera_pitch_deg  # likewise
        self.camera_roll_deg = camera_roll_deg  # likewise
        self.topic = topic
        self.message_type = message_type
        self.name = name
        self.camera = camera
        self.image_size_hw = image_size_hw
        self.stamps_ns = stamps_ns  # exact, for outputs stamped like the images
        self.timestamps_s = stamps_ns / 1e9
        self.frame_count: int | None = len(stamps_ns)
        self.warnings: list[str] = []

    def frames(self) -> Iterator[tuple[float, np.ndarray]]:
        """Yield ``(timestamp_s, image (H, W) uint8 grey)`` per message of the topic, in bag order."""
        height, width = self.image_size_hw
        with _open_reader(self.path) as reader:
            for index, msg in _topic_messages(reader, self.path, self.topic):
                with _image_errors(self.path, self.topic, index):
                    image = image_message_to_grey(msg, self.message_type)
                if image.shape != self.image_size_hw:
                    raise FlowvoError(f"{self.topic} message {index} is {image.shape[1]}x{image.shape[0]}, "
                                      f"the first is {width}x{height}", self.path)
                yield float(self.timestamps_s[index]), image


def open_bag_source(path: str | Path, topic: str, camera_info_topic: str | None = None,
                    intrinsics: CameraIntrinsics | None = None) -> BagSource:
    """Open and validate the images of ``topic`` in the bag at ``path``; intrinsics come from the first
    message of ``camera_info_topic`` or from ``intrinsics`` (exactly one of them).

    Raises a one-line FlowvoError naming the bag (and topic) for a missing path, a file that is no bag, a
    truncated or corrupt bag, a missing topic (listing the image topics present), a topic of another type,
    an unsupported encoding, non-increasing header stamps, images of different sizes and missing intrinsics.
    """
    require_ros_extra("reading ROS bags")
    bag = _check_bag_path(Path(path))
    if camera_info_topic is not None and intrinsics is not None:
        raise FlowvoError("give either a CameraInfo topic or intrinsics (--calib or --fx/--fy/--cx/--cy), not both")
    with _open_reader(bag) as reader:
        message_type = _topic_type(reader, bag, topic, IMAGE_TYPES, "image")
        stamps_ns, image_size_hw = _scan_images(reader, bag, topic, message_type)
        if camera_info_topic is not None:
            camera = _camera_info(reader, bag, camera_info_topic, is_rectified_topic(topic), image_size_hw)
        elif intrinsics is None:
            raise FlowvoError("no camera intrinsics: give --camera-info-topic (CameraInfo topics in the bag: "
                              f"{_list_topics(reader, (CAMERA_INFO_TYPE,))}), --calib or --fx/--fy/--cx/--cy", bag)
        else:
            camera = None  # the given intrinsics describe it
        height_m, mounting_deg = _tf_static_mounting(reader, bag, topic)
    name = safe_source_name(bag.name if bag.is_dir() else bag.stem, "bag")  # a ROS 2 bag is a folder
    return BagSource(bag, topic, message_type, name, camera, image_size_hw,
                     np.asarray(stamps_ns, dtype=np.int64), height_m, *(mounting_deg or (None, None)))


def _tf_static_mounting(reader: Any, bag: Path, topic: str) -> tuple[float | None, tuple[float, float] | None]:
    """The image frame's height above ``base_footprint`` and its pitch below it and roll (degrees) from
    ``/tf_static`` (None each when the bag has no such transforms or they do not connect the two frames)."""
    info = reader.topics.get(TF_STATIC_TOPIC)
    if info is None or info.msgtype != TF_MESSAGE_TYPE:
        return None, None
    with closing(_topic_messages(reader, bag, topic)) as messages:
        camera_frame = next(messages)[1].header.frame_id
    transforms = [StaticTransform(t.header.frame_id, t.child_frame_id,
                                  (t.transform.translation.x, t.transform.translation.y, t.transform.translation.z),
                                  (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
                                   t.transform.rotation.w))
                  for _, msg in _topic_messages(reader, bag, TF_STATIC_TOPIC) for t in msg.transforms]
    return camera_height_m(transforms, camera_frame), camera_mounting_deg(transforms, camera_frame)


def _check_bag_path(path: Path) -> Path:
    if not path.exists():
        raise FlowvoError("no such bag file or folder", path)
    if path.is_dir():
        if not (path / "metadata.yaml").is_file():
            raise FlowvoError("not a ROS 2 bag folder (it has no metadata.yaml)", path)
    elif path.suffix not in BAG_FILE_SUFFIXES:
        raise FlowvoError("not a ROS bag: expected a ROS 1 .bag file, a ROS 2 bag folder, or an .mcap or .db3 file",
                          path)
    return path


def _one_line(error: BaseException) -> str:
    return " ".join(str(error).split()) or type(error).__name__


@contextmanager
def _open_reader(bag: Path) -> Iterator[Any]:
    """An open rosbags AnyReader; bags without embedded message definitions decode as ROS 2 Humble types."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    try:
        reader = AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as error:  # corrupt files fail in many ways; all mean "unreadable"
        hint = "" if bag.is_dir() else _REPAIR_HINTS.get(bag.suffix, "")
        raise FlowvoError(f"cannot read the bag: {_one_line(error)}{hint}", bag) from None
    try:
        yield reader
    finally:
        reader.close()


def _topic_messages(reader: Any, bag: Path, topic: str) -> Iterator[tuple[int, Any]]:
    """(index, deserialized message) of every message of ``topic``, in bag order."""
    connections = [connection for connection in reader.connections if connection.topic == topic]
    try:
        for index, (connection, _, raw) in enumerate(reader.messages(connections=connections)):
            yield index, reader.deserialize(raw, connection.msgtype)
    except Exception as error:  # as in _open_reader
        raise FlowvoError(f"cannot read {topic}: {_one_line(error)}", bag) from None


def _list_topics(reader: Any, types: tuple[str, ...]) -> str:
    names = [f"{name} ({info.msgtype.rsplit('/', 1)[-1]})" for name, info in sorted(reader.topics.items())
             if info.msgtype in types]
    return ", ".join(names) or "none"


def _topic_type(reader: Any, bag: Path, topic: str, types: tuple[str, ...], kind: str) -> str:
    """The message type of ``topic``, which must be one of ``types`` and hold messages."""
    info = reader.topics.get(topic)
    if info is None:
        raise FlowvoError(f"topic {topic} is not in the bag; {kind} topics: {_list_topics(reader, types)}", bag)
    if info.msgtype not in types:
        raise FlowvoError(f"topic {topic} has type {info.msgtype or 'mixed'}, expected "
                          f"{' or '.join(types)}; {kind} topics: {_list_topics(reader, types)}", bag)
    if info.msgcount == 0:
        raise FlowvoError(f"topic {topic} has no messages", bag)
    return info.msgtype


@contextmanager
def _image_errors(bag: Path, topic: str, index: int) -> Iterator[None]:
    """Turn an ImageMessageError into a FlowvoError naming the bag, topic and message."""
    try:
        yield
    except ImageMessageError as error:
        raise FlowvoError(f"{topic} message {index}: {error}", bag) from None


def _scan_images(reader: Any, bag: Path, topic: str, message_type: str) -> tuple[list[int], tuple[int, int]]:
    """Header stamps (ns) of every message and the image size (height, width), checked on every raw image
    and on the first compressed one (``frames()`` checks the others as it decodes them)."""
    stamps_ns: list[int] = []
    size_hw: tuple[int, int] | None = None
    for index, msg in _topic_messages(reader, bag, topic):
        stamp_ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        if stamps_ns and stamp_ns - stamps_ns[-1] < MIN_FRAME_INTERVAL_S * 1e9:
            raise FlowvoError(f"{topic} header stamps must strictly increase, at least {MIN_FRAME_INTERVAL_S:g} s "
                              f"apart: message {index} at {stamp_ns / 1e9:.9f} s follows {stamps_ns[-1] / 1e9:.9f} s",
                              bag)
        stamps_ns.append(stamp_ns)
        if message_type != IMAGE_TYPE and size_hw is not None:
            continue
        with _image_errors(bag, topic, index):
            this_hw = raw_image_size_hw(msg) if message_type == IMAGE_TYPE else compressed_image_to_grey(msg).shape
        if size_hw is not None and this_hw != size_hw:
            raise FlowvoError(f"{topic} message {index} is {this_hw[1]}x{this_hw[0]}, "
                              f"the first is {size_hw[1]}x{size_hw[0]}", bag)
        size_hw = this_hw
    if size_hw is None:  # the bag's index promised messages that are not there
        raise FlowvoError(f"topic {topic} has no readable messages", bag)
    return stamps_ns, size_hw


def _camera_info(reader: Any, bag: Path, topic: str, rectified: bool, image_size_hw: tuple[int, int]
                 ) -> Camera:
    """The camera of the first message of the CameraInfo ``topic`` (see ``camera_info_intrinsics`` and
    ``camera_info_distortion``)."""
    _topic_type(reader, bag, topic, (CAMERA_INFO_TYPE,), "CameraInfo")
    with closing(_topic_messages(reader, bag, topic)) as messages:
        _, msg = next(messages)
    try:
        return Camera(camera_info_intrinsics(msg, rectified, image_size_hw), camera_info_distortion(msg, rectified),
                      source="camera_info")
    except CameraInfoError as error:
        raise FlowvoError(f"{topic}: {error}", bag) from None
