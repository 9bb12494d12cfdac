"""What every frame source provides: grey frames with timestamps, its own camera description, a name.

A source is consumed once, in order, frame by frame (``frames()``), so a video or a bag never has to fit
in memory. Optional ground truth lets ``flowvo run`` evaluate what it can.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Protocol

import numpy as np

from flowvo.camera import Camera
from flowvo.trajectory import Trajectory


class FrameSource(Protocol):
    """A drive to run odometry on.

    ``name``: used for output files (``NAME.txt``, ``NAME.tum``); a plain name, never a path.
    ``camera``: what the drive itself says of its camera (KITTI calib.txt, a ROS CameraInfo), in pixels of
    the frames as ``frames()`` yields them; None when it says nothing (a video).
    ``camera_height_m``: the camera's height above the road when the drive says it (a bag's /tf_static, a
    KITTI calib.txt line), else None; ``camera_pitch_deg`` likewise its pitch below the road (degrees, down
    positive), ``camera_roll_deg`` its roll about the optical axis after the pitch (degrees, right side down
    positive).
    ``image_size_hw``: (height, width) of every frame.
    ``frame_count``: number of frames when known in advance (None for streams of unknown length).
    ``ground_truth``: camera-to-world poses per frame when the source has them, else None.
    ``frames()``: yields ``(timestamp_s, image)`` in order, image (H, W) uint8 grey; timestamps strictly
    increasing, at least :data:`MIN_FRAME_INTERVAL_S` apart, in seconds (KITTI: times.txt; video: container
    time; bags: header stamps).
    ``warnings``: what the source had to work around while reading (a video that ended before the frame
    count its container states), one line each, filled as ``frames()`` runs; recorded in run.json.
    ``is_synthetic``: True for frames flowvo rendered itself.
    ``stamps_ns``: the frames' stamps as integer nanoseconds when the source has them exactly (bag header
    stamps: float seconds since 1970 lose up to ~120 ns), else None.
    """

    name: str
    camera: Camera | None
    camera_height_m: float | None
    camera_pitch_deg: float | None
    camera_roll_deg: float | None
    stamps_ns: np.ndarray | None
    image_size_hw: tuple[int, int]
    frame_count: int | None
    ground_truth: Trajectory | None
    is_synthetic: bool
    warnings: list[str]

    def frames(self) -> Iterator[tuple[float, np.ndarray]]: ...


def safe_source_name(stem: str, fallback: str) -> str:
    """A plain name for output files from a file or folder stem: characters outside [A-Za-z0-9_-] become
    '_'; ``fallback`` when nothing is left."""
    return re.sub(r"[^A-Za-z0-9_-]", "_", stem) or fallback
