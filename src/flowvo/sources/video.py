"""Frames of a video file, in any container and codec OpenCV reads, converted to grey.

``open_video_source`` validates before any output exists: the file exists, OpenCV opens it and its first
frame decodes. A video carries no camera description: the camera comes from the user (or is estimated).
Then:

- Images: OpenCV's decoded frames (colour converted to grey with ``cv2.COLOR_BGR2GRAY``), all of the
  first frame's size; intrinsics must be in pixels of these frames. OpenCV resamples a frame whose coded
  size changes mid-stream to the first frame's size without a word (intrinsics of the wrong scale): for
  Motion JPEG, whose frames are JPEG images, each frame's coded size is read from its JPEG header and a
  change is an error.
- Timestamps: the container's presentation time of each frame (``CAP_PROP_POS_MSEC`` after decoding it),
  in seconds. Where a frame's time is missing or does not increase by at least
  :data:`~flowvo.trajectory.MIN_FRAME_INTERVAL_S` (raw streams report 0 for every frame; a damaged index
  can repeat a time), it gets the previous time plus one frame interval (1 / ``CAP_PROP_FPS``), so times
  always strictly increase; a warning is logged once per stream. Such a frame in a container that states
  no frame rate (or one beyond 10,000 frames/s) is an error.
- End: the stream ends where decoding ends. Decoding that ends before the frame count the container
  states (a file cut short, a damaged tail) ends the drive at its last good frame, with a warning (logged,
  and kept in ``warnings`` for run.json). Containers that estimate their count from duration x frame rate
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
from flowvo.trajectory import MIN_FRAME_INTERVAL_S, Trajectory

_log = logging.getLogger(__name__)
MOTION_JPEG_FOURCCS = ("MJPG", "mjpg", "AVRn", "LJPG", "JPGL", "jpeg", "dmb1")  # frames that are JPEG images
_JPEG_FRAME_MARKERS = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}  # SOFn


class VideoSource:
    """A FrameSource over the frames of the video at ``path`` (build it with :func:`open_video_source`).

    ``frame_rate_hz``: the container's frame rate, None when it states none. ``frame_count``: the
    container's frame count, None when it states none. ``fourcc``: the codec's four characters.
    ``warnings``: what the last full read had to work around (an early end), one line each.
    """

    ground_truth: Trajectory | None = None
    is_synthetic: bool = False
    camera: Camera | None = None  # a video carries no camera description
    camera_height_m: float | None = None
    camera_pitch_deg: float | None = None
    camera_roll_deg: float | None = None
    stamps_ns: np.ndarray | None = None

    def __init__(self, path: Path, name: str, image_size_hw: tuple[int, int], frame_count: int | None,
                 frame_rate_hz: float | None, fourcc: str = "") -> None:
        self.path = path
        self.name = name
        self.image_size_hw = image_size_hw
        self.frame_count = frame_count
        self.frame_rate_hz = frame_rate_hz
        self.fourcc = fourcc
        self.warnings: list[str] = []

    def frames(self) -> Iterator[tuple[float, np.ndarray]]:
        """Yield ``(timestamp_s, image (H, W) uint8 grey)`` per frame, decoding from the start each call."""
        capture = _open_capture(self.path)
        coded = _open_packets(self.path) if self.fourcc in MOTION_JPEG_FOURCCS else None
        index, previous_s, warned = 0, None, False
        self.warnings = []
        try:
            while True:
                ok, frame = capture.read()
                if not ok:
                    break
                image = _grey(frame)
                coded_hw = _next_jpeg_size_hw(coded) if coded is not None else None
                size_hw = coded_hw or image.shape
                if size_hw != self.image_size_hw:
                    raise FlowvoError(f"frame {index} is {size_hw[1]}x{size_hw[0]}, the first is "
                                      f"{self.image_size_hw[1]}x{self.image_size_hw[0]}: a video must keep one frame "
                                      "size (OpenCV would resample it to the first's)", self.path)
                container_ms = capture.get(cv2.CAP_PROP_POS_MSEC)
                time_s = next_timestamp_s(container_ms, previous_s, self.frame_rate_hz)
                if time_s is None:
                    raise FlowvoError(f"frame {index} has no increasing container timestamp and the container "
                                      "states no frame rate (or one beyond 10,000 frames/s)", self.path)
                if not warned and time_s != container_ms / 1000.0:
                    _log.warning("%s: frame %d has no increasing container timestamp; from there on, such frames "
                                 "are timed by the frame rate", self.path, index)
                    warned = True
                yield time_s, image
                index, previous_s = index + 1, time_s
        finally:
            capture.release()
            if coded is not None:
                coded.release()
        if self.frame_count is not None and index < self.frame_count:
            warning = (f"{self.path}: decoding stopped after {index} of the {self.frame_count} frames the container "
                       "states (file cut short or damaged): the drive ends at its last good frame")
            self.warnings.append(warning)
            _log.warning("warning: %s", warning)


def open_video_source(path: str | Path) -> VideoSource:
    """A validated :class:`VideoSource`.

    Raises a one-line FlowvoError naming the file when it is missing, OpenCV cannot open it or its first
    frame does not decode.
    """
    path = check_path_text(path, "--video")  # OpenCV crashes the process on names that are not UTF-8
    if not path.is_file():
        raise FlowvoError("video file not found" if not path.exists() else
                          "is not a regular file (a folder, a FIFO or a device): give a video file", path)
    capture = _open_capture(path)
    try:
        ok, frame = capture.read()
        frame_count = capture.get(cv2.CAP_PROP_FRAME_COUNT)
        frame_rate_hz = capture.get(cv2.CAP_PROP_FPS)
        fourcc_code = capture.get(cv2.CAP_PROP_FOURCC)
    finally:
        capture.release()
    if not ok:
        raise FlowvoError("the first frame does not decode (empty, truncated or damaged video)", path)
    fourcc = _fourcc_text(fourcc_code)
    image_size_hw = _grey(frame).shape
    if fourcc in MOTION_JPEG_FOURCCS:
        packets = _open_packets(path)
        try:
            image_size_hw = _next_jpeg_size_hw(packets) or image_size_hw
        finally:
            packets.release()
    count = int(frame_count) if math.isfinite(frame_count) and 0 < frame_count < 2**62 else None
    return VideoSource(path, safe_source_name(path.stem, "video"), image_size_hw, count,
                       frame_rate_hz if math.isfinite(frame_rate_hz) and frame_rate_hz > 0 else None, fourcc)


def next_timestamp_s(container_ms: float, previous_s: float | None, frame_rate_hz: float | None) -> float | None:
    """A frame's time in seconds: the container's ``container_ms`` / 1000 when finite, non-negative and after
    ``previous_s``; else ``previous_s`` + 1 / ``frame_rate_hz`` (0 for the first frame); None when that
    needs a frame rate and there is none."""
    container_s = container_ms / 1000.0
    if math.isfinite(container_s) and container_s >= 0 and \
            (previous_s is None or container_s - previous_s >= MIN_FRAME_INTERVAL_S):
        return container_s
    if previous_s is None:
        return 0.0
    if frame_rate_hz is None or 1.0 / frame_rate_hz < MIN_FRAME_INTERVAL_S:
        return None
    return previous_s + 1.0 / frame_rate_hz


def _open_capture(path: Path) -> cv2.VideoCapture:
    capture = cv2.VideoCapture(str(path))
    if not capture.isOpened():
        capture.release()
        raise FlowvoError("OpenCV cannot open this file as a video (not a video, empty, or a codec this OpenCV "
                          "build lacks)", path)
    return capture


def _fourcc_text(code: float) -> str:
    """The four characters of OpenCV's ``CAP_PROP_FOURCC`` number ("" when it states none)."""
    if not math.isfinite(code) or code <= 0:
        return ""
    return int(code).to_bytes(4, "little").decode("latin-1").strip("\x00 ")


def _open_packets(path: Path) -> cv2.VideoCapture:
    """A second capture of ``path`` that yields each frame's coded bytes undecoded (OpenCV's raw mode)."""
    capture = _open_capture(path)
    capture.set(cv2.CAP_PROP_FORMAT, -1)
    return capture


def _next_jpeg_size_hw(packets: cv2.VideoCapture) -> tuple[int, int] | None:
    """(height, width) from the JPEG header of the next Motion JPEG frame; None when it cannot be read."""
    ok, packet = packets.read()
    if not ok or packet is None:
        return None
    return jpeg_size_hw(np.asarray(packet, dtype=np.uint8).tobytes())


def jpeg_size_hw(data: bytes) -> tuple[int, int] | None:
    """(height, width) of the JPEG image ``data`` from its frame header (SOFn), without decoding it; None
    when ``data`` is not a JPEG or has no frame header."""
    if data[:2] != b"\xff\xd8":
        return None
    i = 2
    while i + 4 <= len(data):
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker in _JPEG_FRAME_MARKERS and i + 9 <= len(data):
            return int.from_bytes(data[i + 5:i + 7], "big"), int.from_bytes(data[i + 7:i + 9], "big")
        if marker in (0xD9, 0xDA):  # end of image, start of scan: no frame header before them
            return None
        i += 2 + int.from_bytes(data[i + 2:i + 4], "big")
    return None


def _grey(frame: np.ndarray) -> np.ndarray:
    """Grey (H, W) uint8 of a decoded frame: BGR, BGRA or already grey."""
    if frame.ndim == 2:
        return frame
    code = cv2.COLOR_BGRA2GRAY if frame.shape[2] == 4 else cv2.COLOR_BGR2GRAY
    return cv2.cvtColor(frame, code)
