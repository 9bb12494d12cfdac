"""The camera of a drive that comes without one (a video, no ``--calib``, no ``--fx``): its focal length and
lens distortion estimated from the motion in its first frames (:mod:`flowvo.calibration.focal_from_motion`),
or a one-line error saying why that is not possible and how to calibrate instead.

Frames are tracked at ``ESTIMATION_WIDTH_PX`` (as the default method works), but every focal length,
principal point and radius this module returns, records or puts in a message is in pixels of the frames as
decoded."""

from __future__ import annotations

from dataclasses import dataclass
from itertools import islice

import cv2

from flowvo.calibration.focal_from_motion import FocalEstimate, estimate_focal, principal_point
from flowvo.calibration.motion_pairs import motion_pairs
from flowvo.camera import Camera, CameraIntrinsics, LensDistortion
from flowvo.errors import FlowvoError
from flowvo.methods.base import REFERENCE_WIDTH_PX
from flowvo.progress import progress
from flowvo.sources.base import FrameSource

ESTIMATION_FRAMES = 300  # frames decoded for the estimate: 30 s at 10 frames/s, 10 s at 30; a drive seldom
# goes that long without a turn
ESTIMATION_WIDTH_PX = REFERENCE_WIDTH_PX  # frames are tracked at this width (never enlarged), as the
# default method tracks them


@dataclass(frozen=True)
class EstimatedCamera:
    """The estimated ``camera`` (pixels of the drive's frames as decoded, source "estimated"), the
    ``estimate`` it comes from (the same pixels), how many ``frames`` were decoded for it, the frames' size
    ``image_size_hw`` and the width they were tracked at, ``tracked_width_px``."""

    camera: Camera
    estimate: FocalEstimate
    frames: int
    image_size_hw: tuple[int, int]
    tracked_width_px: int

    def record(self) -> dict:
        """What ``run.json`` records of the estimate."""
        h, w = self.image_size_hw
        return {**self.estimate.record(), "frames": self.frames, "image_size": [w, h],
                "pixels": f"of the {w}x{h} frames as decoded (tracked at {self.tracked_width_px} px wide, every "
                          "length here scaled back)"}


def estimate_camera(source: FrameSource, where: str, max_frames: int = ESTIMATION_FRAMES,
                    distortion: LensDistortion | None = None) -> EstimatedCamera:
    """Decode the first ``max_frames`` frames of ``source`` (all when it is shorter), estimate the focal
    length (square pixels, principal point at the image centre) and the lens's distortion, or the focal
    length alone through the lens ``distortion`` when it is given (``--dist``); a FlowvoError naming
    ``where`` (the video) when the motion does not determine them."""
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
    estimate = estimate_focal(pairs, working_hw, distortion, frame_scale=w / working_hw[1])
    if not estimate.observable:
        raise FlowvoError(f"no camera intrinsics, and the focal length cannot be estimated from the motion in the "
                          f"first {decoded} frames: {estimate.reason}. {_advice(estimate, (h, w))}", where)
    cx, cy = principal_point(source.image_size_hw)
    lens = estimate.distortion if estimate.lens_estimated else LensDistortion()  # a given lens stays the user's
    camera = Camera(CameraIntrinsics(estimate.focal_px, estimate.focal_px, cx, cy), lens, source="estimated")
    return EstimatedCamera(camera, estimate, decoded, (h, w), working_hw[1])


def _advice(estimate: FocalEstimate, image_size_hw: tuple[int, int]) -> str:
    """What to do instead, for the reason the estimate gave."""
    h, w = image_size_hw
    why = "Only turns show the focal length, a straight drive does not: c" if "turns too little" in estimate.reason \
        else "C"
    return (f"{why}alibrate the camera with a printed chessboard ('flowvo calibrate', docs/calibrate.md) and give "
            f"--calib FILE, or give --fx --fy --cx --cy (pixels of the {w}x{h} frames) and, for a wide-angle lens, "
            "--dist K1 K2 P1 P2")
