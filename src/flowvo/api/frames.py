"""Frames handed in from Python: checked and made into the grey (H, W) uint8 images every source gives a method.

Taken as the command line's sources give them: grey (H, W) or (H, W, 1); colour (H, W, 3) or (H, W, 4) in
``channel_order`` ("bgr", OpenCV's and the video source's, or "rgb"), converted with OpenCV's BT.601 weights;
16-bit frames keep their high byte (``value >> 8``), as a ROS ``mono16`` image does. Anything else (floating
point, bool, other shapes) is refused with one line saying what was given and what is taken. Times are seconds,
finite and strictly increasing (:func:`flowvo.drive.stream.check_frame_time`, the stream's own check).
"""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np

from flowvo.errors import FlowvoError

CHANNEL_ORDERS = ("bgr", "rgb")


def check_channel_order(channel_order: str) -> str:
    """``channel_order`` when it is one of :data:`CHANNEL_ORDERS`; a one-line error otherwise."""
    if channel_order not in CHANNEL_ORDERS:
        raise FlowvoError(f"channel_order must be one of {', '.join(CHANNEL_ORDERS)}, got {channel_order!r}")
    return channel_order


def frame_time_s(time_s: Any, index: int) -> float:
    """A frame's time as float seconds; a one-line error for anything that is not a real number."""
    if isinstance(time_s, bool) or not isinstance(time_s, numbers.Real):
        raise FlowvoError(f"frame {index}: time_s must be a number of seconds, got {type(time_s).__name__} "
                          f"{time_s!r}")
    return float(time_s)


def grey_frame(image: Any, index: int, channel_order: str = "bgr") -> np.ndarray:
    """The grey (H, W) uint8 frame of ``image`` (see the module docstring); frame ``index`` names it in errors."""
    import cv2

    if not isinstance(image, np.ndarray):
        raise FlowvoError(f"frame {index}: expected a NumPy array (H, W) or (H, W, 3), got {type(image).__name__}")
    if image.dtype not in (np.uint8, np.uint16):
        raise FlowvoError(f"frame {index}: pixels of type {image.dtype} are not taken; give uint8 (or uint16) "
                          "frames, e.g. (255 * image).astype(np.uint8) for floats in [0, 1]")
    channels = 1 if image.ndim == 2 else image.shape[2] if image.ndim == 3 else None
    if channels not in (1, 3, 4) or min(image.shape[:2]) < 1:
        raise FlowvoError(f"frame {index}: shape {image.shape} is not a frame; give (H, W) grey, (H, W, 3) or "
                          "(H, W, 4) colour")
    if image.dtype == np.uint16:
        image = (image >> 8).astype(np.uint8)
    if channels == 1:
        return image.reshape(image.shape[:2])
    code = {("bgr", 3): cv2.COLOR_BGR2GRAY, ("bgr", 4): cv2.COLOR_BGRA2GRAY,
            ("rgb", 3): cv2.COLOR_RGB2GRAY, ("rgb", 4): cv2.COLOR_RGBA2GRAY}[channel_order, channels]
    return cv2.cvtColor(np.ascontiguousarray(image), code)


class FrameChecks:
    """Each frame of a drive checked in turn: its time (seconds, finite, after the last), its pixels (see
    :func:`grey_frame`) and its size (that of the first frame)."""

    def __init__(self, channel_order: str = "bgr") -> None:
        self.channel_order = check_channel_order(channel_order)
        self.count = 0
        self.last_time_s: float | None = None
        self.size_hw: tuple[int, int] | None = None

    def check(self, image: Any, time_s: Any) -> tuple[float, np.ndarray]:
        """``(time_s, grey frame)`` of the next frame; a one-line error (and nothing counted) when it is wrong."""
        from flowvo.drive.stream import check_frame_time

        index = self.count
        time_s = frame_time_s(time_s, index)
        check_frame_time(index, time_s, self.last_time_s)
        grey = grey_frame(image, index, self.channel_order)
        if self.size_hw is not None and grey.shape != self.size_hw:
            raise FlowvoError(f"frame {index} is {grey.shape[1]}x{grey.shape[0]} px, the drive's first frame "
                              f"{self.size_hw[1]}x{self.size_hw[0]}: every frame of a drive must have one size")
        self.size_hw = grey.shape
        self.count, self.last_time_s = index + 1, time_s
        return time_s, grey

