"""sensor_msgs/Image and sensor_msgs/CompressedImage messages to grey uint8 frames.

Supported ``Image`` encodings: mono8 (and its alias 8UC1), rgb8, bgr8, rgba8, bgra8 (converted to grey with
OpenCV's BT.601 weights, exact for grey pixels) and mono16, mapped to 8 bits by keeping the high byte
(``value >> 8``): one fixed mapping for every frame, so brightness stays constant across frames as optical
flow needs; 10/12-bit cameras that fill only the low bits of mono16 come out dark. Depth encodings (16UC1,
32FC1) and Bayer patterns are refused.

``CompressedImage``: any format OpenCV decodes (png, jpeg, ...), decoded straight to grey; the
``compressedDepth`` format of depth images is refused.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

IMAGE_TYPE = "sensor_msgs/msg/Image"
COMPRESSED_IMAGE_TYPE = "sensor_msgs/msg/CompressedImage"
IMAGE_TYPES = (IMAGE_TYPE, COMPRESSED_IMAGE_TYPE)


@dataclass(frozen=True)
class _Encoding:
    channels: int
    bytes_per_channel: int
    to_grey: int | None  # cv2 colour conversion code, None for single-channel encodings


_ENCODINGS = {
    "mono8": _Encoding(1, 1, None),
    "8UC1": _Encoding(1, 1, None),
    "mono16": _Encoding(1, 2, None),
    "rgb8": _Encoding(3, 1, cv2.COLOR_RGB2GRAY),
    "bgr8": _Encoding(3, 1, cv2.COLOR_BGR2GRAY),
    "rgba8": _Encoding(4, 1, cv2.COLOR_RGBA2GRAY),
    "bgra8": _Encoding(4, 1, cv2.COLOR_BGRA2GRAY),
}
SUPPORTED_ENCODINGS = tuple(_ENCODINGS)


class ImageMessageError(ValueError):
    """An image message flowvo cannot turn into a grey frame; the message says why."""


def raw_image_size_hw(msg: Any) -> tuple[int, int]:
    """(height, width) of a sensor_msgs/Image after checking its encoding, row stride and data length."""
    encoding = _ENCODINGS.get(msg.encoding)
    if encoding is None:
        raise ImageMessageError(f"unsupported encoding {msg.encoding!r}; supported: {', '.join(SUPPORTED_ENCODINGS)}")
    row_bytes = msg.width * encoding.channels * encoding.bytes_per_channel
    if msg.height == 0 or msg.width == 0:
        raise ImageMessageError(f"empty image ({msg.width}x{msg.height})")
    if msg.step < row_bytes:
        raise ImageMessageError(f"row step {msg.step} bytes is shorter than a {msg.width}-pixel {msg.encoding} row")
    if len(msg.data) < msg.step * msg.height:
        raise ImageMessageError(f"has {len(msg.data)} data bytes, {msg.step * msg.height} expected "
                                f"({msg.height} rows of {msg.step} bytes)")
    return int(msg.height), int(msg.width)


def raw_image_to_grey(msg: Any) -> np.ndarray:
    """Grey (H, W) uint8 pixels of a sensor_msgs/Image (checked as ``raw_image_size_hw`` does)."""
    height, width = raw_image_size_hw(msg)
    encoding = _ENCODINGS[msg.encoding]
    dtype = np.dtype(np.uint8) if encoding.bytes_per_channel == 1 else np.dtype(">u2" if msg.is_bigendian else "<u2")
    rows = np.asarray(msg.data, dtype=np.uint8)[: msg.step * height].reshape(height, msg.step)
    row_bytes = width * encoding.channels * encoding.bytes_per_channel
    pixels = np.ascontiguousarray(rows[:, :row_bytes]).view(dtype).reshape(height, width, encoding.channels)
    if encoding.bytes_per_channel == 2:
        return (pixels[..., 0] >> 8).astype(np.uint8)
    if encoding.to_grey is None:
        return pixels[..., 0].copy()
    return cv2.cvtColor(pixels, encoding.to_grey)


def compressed_image_to_grey(msg: Any) -> np.ndarray:
    """Grey (H, W) uint8 pixels of a sensor_msgs/CompressedImage (png, jpeg, ... as OpenCV decodes them)."""
    if "compresseddepth" in msg.format.lower():
        raise ImageMessageError(f"format {msg.format!r} is a compressed depth image, not a camera image")
    image = cv2.imdecode(np.asarray(msg.data, dtype=np.uint8), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise ImageMessageError(f"cannot decode the compressed image (format {msg.format!r})")
    return image


def image_message_to_grey(msg: Any, msgtype: str) -> np.ndarray:
    """Grey (H, W) uint8 pixels of an Image or CompressedImage message of type ``msgtype``."""
    return raw_image_to_grey(msg) if msgtype == IMAGE_TYPE else compressed_image_to_grey(msg)
