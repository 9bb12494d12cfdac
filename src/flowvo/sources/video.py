"""Frames of a video file, in any container and codec OpenCV reads, converted to grey.

``open_video_source`` validates before any output exists: the file exists, OpenCV opens it and its first
frame decodes. A video carries no camera description: the camera comes from the user (or is estimated).
Then:

- Images: OpenCV's decoded frames (colour converted to grey with ``cv2.COLOR_BGR2GRAY``), all of the
  first frame's size; intrinsics must be in pixels of these frames.
- Timestamps: the container's presentation time of each frame (``CAP_PROP_POS_MSEC`` after decoding it),
  in seconds. Where a frame's time is missing or does not increase (raw streams report 0 for every frame;
  a damaged index can repeat a time), it gets the previous time plus one frame interval
  (1 / ``CAP_PROP_FPS``), so times always strictly increase; a warning is logged once per stream. Such a
  frame in a container that states no frame rate is an error.
- End: the stream ends where decoding ends. Decoding that ends before the frame count the container
  states means a truncated or damaged file, and ``frames()`` raises there rather than return poses that
  silently miss the end of the drive. Containers that estimate their count from duration x frame rate
  (Matroska, MPEG-TS) can overstate it for a variable frame rate; remuxing to MP4
  (``ffmpeg -i in.mkv -c copy out.mp4``) gives an exact count.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from flowvo.camera import Camera
from flowvo.errors import FlowvoError
from flowvo.io.outputs import check_path_text
from flowvo.sources.base import safe_source_name
from flowvo.trajectory import Trajectory

_log = logging.getLogger(__name__)


class VideoSource:
    """A FrameSource over the frames of the video at ``path`` (build it with :func:`open_video_source`).

    ``frame_rate_hz``: the container's frame rate, None when it states none. ``frame_count``: the
    container's frame count, None when it states none.
    """

    ground_truth: Trajectory | None = None
    is_synthetic: bool = False
    camera: Camera | None = None  # a video carries no camera description
    camera_height_m: float | None = None
    camera_pitch_deg: float | None = None
    stamps_ns: np.ndarray | None = None

    def __init__(self, path: Path, name: str, image_size_hw: tuple[int, int], frame_count: int | None,
                 frame_rate_hz: float | None) -> None:
        self.path = path
        self.name = name
        self.image_size_hw = image_size_hw
        self.frame_count = frame_count
        self.frame_rate_hz = frame_rate_hz

    def frames(self) -> Iterator[tuple[float, np.ndarray]]:
        """Yield ``(timestamp_s, image (H, W) uint8 grey)`` per frame, decoding from the start each call."""
        capture = _open_capture(self.path)
        index, previous_s, warned = 0, None, False
        try:
            while True:
                ok, frame = capture.read()
                if not ok:
                    break
                image = _grey(frame)
                if image.shape != self.image_size_hw:
                    raise FlowvoError(f"frame {index} is {image.shape[1]}x{image.shape[0]}, the first is "
                                      f"{self.image_size_hw[1]}x{self.image_size_hw[0]}", self.path)
                container_ms = capture.get(cv2.CAP_PROP_POS_MSEC)
                time_s = next_timestamp_s(container_ms, previous_s, self.frame_rate_hz)
                if time_s is None:
                    raise FlowvoError(f"frame {index} has no increasing container timestamp and the container "
                                      "states no frame rate", self.path)
                if not warned and time_s != container_ms / 1000.0:
                    _log.warning("%s: frame %d has no increasing container timestamp; from there on, such frames "
                                 "are timed by the frame rate", self.path, index)
                    warned = True
                yield time_s, image
                index, previous_s = index + 1, time_s
        finally:
            capture.release()
        if self.frame_count is not None and index < self.frame_count:
            raise FlowvoError(f"decoding stopped after {index} of the {self.frame_count} frames the container "
                              "states: truncated or damaged file", self.path)


def open_video_source(path: str | Path) -> VideoSource:
    """A validated :class:`VideoSource`.

    Raises a one-line FlowvoError naming the file when it is missing, OpenCV cannot open it or its first
    frame does not decode.
    """
    path = check_path_text(path, "--video")  # OpenCV crashes the process on names that are not UTF-8
    if not path.is_file():
        raise FlowvoError("video file not found", path)
    capture = _open_capture(path)
    try:
        ok, frame = capture.read()
        frame_count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
        frame_rate_hz = capture.get(cv2.CAP_PROP_FPS)
    finally:
        capture.release()
    if not ok:
        raise FlowvoError("the first frame does not decode (empty, truncated or damaged video)", path)
    image_size_hw = _grey(frame).shape
    return VideoSource(path, safe_source_name(path.stem, "video"), image_size_hw,
                       frame_count if frame_count > 0 else None,
                       frame_rate_hz if math.isfinite(frame_rate_hz) and frame_rate_hz > 0 else None)


def next_timestamp_s(container_ms: float, previous_s: float | None, frame_rate_hz: float | None) -> float | None:
    """A frame's time in seconds: the container's ``container_ms`` / 1000 when finite, non-negative and after
    ``previous_s``; else ``previous_s`` + 1 / ``frame_rate_hz`` (0 for the first frame); None when that
    needs a frame rate and there is none."""
    container_s = container_ms / 1000.0
    if math.isfinite(container_s) and container_s >= 0 and (previous_s is None or container_s > previous_s):
        return container_s
    if previous_s is None:
        return 0.0
    if frame_rate_hz is None:
        return None
    return previous_s + 1.0 / frame_rate_hz


def _open_capture(path: Path) -> cv2.VideoCapture:
    capture = cv2.VideoCapture(str(path))
    if not capture.isOpened():
        capture.release()
        raise FlowvoError("OpenCV cannot open this file as a video (not a video, empty, or a codec this OpenCV "
                          "build lacks)", path)
    return capture


def _grey(frame: np.ndarray) -> np.ndarray:
    """Grey (H, W) uint8 of a decoded frame: BGR, BGRA or already grey."""
    if frame.ndim == 2:
        return frame
    code = cv2.COLOR_BGRA2GRAY if frame.shape[2] == 4 else cv2.COLOR_BGR2GRAY
    return cv2.cvtColor(frame, code)
