"""The camera of a drive that comes without one (a video, no ``--calib``, no ``--fx``): its focal length
estimated from the motion in its first frames (:mod:`flowvo.calibration.focal_from_motion`), or a one-line
error saying why that is not possible and how to calibrate instead."""

from __future__ import annotations

from dataclasses import dataclass
from itertools import islice

import cv2

from flowvo.calibration.focal_from_motion import FocalEstimate, estimate_focal, principal_point
from flowvo.calibration.motion_pairs import motion_pairs
from flowvo.camera import Camera, CameraIntrinsics
from flowvo.errors import FlowvoError
from flowvo.methods.base import REFERENCE_WIDTH_PX
from flowvo.progress import progress
from flowvo.sources.base import FrameSource

ESTIMATION_FRAMES = 300  # frames decoded for the estimate: 30 s at 10 frames/s, 10 s at 30; a drive seldom
# goes that long without a turn, and the estimate takes ~10 s on two cores
ESTIMATION_WIDTH_PX = REFERENCE_WIDTH_PX  # frames are tracked at this width (never enlarged), as the
# default method tracks them


@dataclass(frozen=True)
class EstimatedCamera:
    """The estimated ``camera`` (pixels of the drive's frames, source "estimated"), the ``estimate`` it
    comes from (at the same pixels) and how many ``frames`` were decoded for it."""

    camera: Camera
    estimate: FocalEstimate
    frames: int

    def record(self) -> dict:
        """What ``run.json`` records of the estimate."""
        return {**self.estimate.record(), "frames": self.frames}


def estimate_camera(source: FrameSource, where: str, max_frames: int = ESTIMATION_FRAMES) -> EstimatedCamera:
    """Decode the first ``max_frames`` frames of ``source`` (all when it is shorter), estimate the focal
    length (square pixels, principal point at the image centre, no distortion); a FlowvoError naming
    ``where`` (the video) when the motion does not determine it."""
    h, w = source.image_size_hw
    scale = min(1.0, ESTIMATION_WIDTH_PX / w)
    working_hw = (max(1, round(h * scale)), max(1, round(w * scale)))
    total = max_frames if source.frame_count is None else min(max_frames, source.frame_count)
    decoded = 0

    def working_frames():
        nonlocal decoded
        for _, image in progress(islice(source.frames(), max_frames), "estimating the focal length", total,
                                 "frame"):
            decoded += 1
            yield cv2.resize(image, working_hw[::-1], interpolation=cv2.INTER_AREA) if scale < 1.0 else image

    pairs = motion_pairs(working_frames(), working_hw[1] / REFERENCE_WIDTH_PX)
    estimate = estimate_focal(pairs, working_hw).scaled(w / working_hw[1])
    if not estimate.observable:
        raise FlowvoError(f"no camera intrinsics, and the focal length cannot be estimated from the motion in the "
                          f"first {decoded} frames: {estimate.reason}. Only turns show the focal length, a straight "
                          "drive does not: calibrate the camera ('flowvo calibrate') and give --calib FILE, or give "
                          "--fx --fy --cx --cy", where)
    cx, cy = principal_point(source.image_size_hw)
    camera = Camera(CameraIntrinsics(estimate.focal_px, estimate.focal_px, cx, cy), source="estimated")
    return EstimatedCamera(camera, estimate, decoded)
