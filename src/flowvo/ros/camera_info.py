"""Pinhole intrinsics from a sensor_msgs/CameraInfo message (ROS 1 field names K, P or ROS 2 k, p).

ROS semantics (image_geometry): ``K`` describes the raw, distorted image; ``P`` (its left 3x3) the rectified
image that image_proc publishes as ``image_rect*``. Frames from a rectified topic use P and no distortion;
frames from any other topic use K and the distortion ``D`` of ``distortion_model`` (plumb_bob,
rational_polynomial, equidistant), which flowvo removes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from flowvo.camera import NO_DISTORTION, CameraIntrinsics, LensDistortion
from flowvo.errors import FlowvoError

CAMERA_INFO_TYPE = "sensor_msgs/msg/CameraInfo"


class CameraInfoError(ValueError):
    """A CameraInfo message that yields no usable intrinsics; the message says why."""


def is_rectified_topic(image_topic: str) -> bool:
    """True when a name component of the topic starts with ``image_rect`` (image_proc's naming)."""
    return any(part.startswith("image_rect") for part in image_topic.split("/"))


def camera_info_intrinsics(msg: Any, rectified: bool, image_size_hw: tuple[int, int]) -> CameraIntrinsics:
    """Intrinsics in pixels of the images ``msg`` describes: from P when ``rectified``, else from K.

    Refuses an all-zero matrix (an uncalibrated camera) and a CameraInfo whose width and height (when set)
    differ from ``image_size_hw`` (height, width) of the images.
    """
    if rectified:
        name, values = "P", np.asarray(_field(msg, "p"), dtype=np.float64).reshape(3, 4)
    else:
        name, values = "K", np.asarray(_field(msg, "k"), dtype=np.float64).reshape(3, 3)
    if not np.any(values):
        raise CameraInfoError(f"CameraInfo {name} is all zero (the camera is not calibrated)")
    height, width = image_size_hw
    if msg.width and msg.height and (msg.width, msg.height) != (width, height):
        raise CameraInfoError(f"CameraInfo is for {msg.width}x{msg.height} images, the frames are {width}x{height}")
    return CameraIntrinsics.from_matrix(values)


def _field(msg: Any, name: str) -> Any:
    """A matrix field by its ROS 2 (lower-case) or ROS 1 (upper-case) name."""
    return getattr(msg, name) if hasattr(msg, name) else getattr(msg, name.upper())


def camera_info_distortion(msg: Any, rectified: bool) -> LensDistortion:
    """The lens distortion of the images ``msg`` describes: none for rectified images, else ``D`` of
    ``distortion_model`` (an empty ``D`` is no distortion)."""
    if rectified:
        return NO_DISTORTION
    coefficients = tuple(float(v) for v in np.asarray(_field(msg, "d"), dtype=np.float64).ravel())
    model = str(getattr(msg, "distortion_model", "") or "plumb_bob")
    if model == "rational_polynomial" and len(coefficients) > 8:
        coefficients = coefficients[:8]
    try:
        return LensDistortion(model, coefficients)
    except FlowvoError as error:
        raise CameraInfoError(f"CameraInfo D: {error}") from None
