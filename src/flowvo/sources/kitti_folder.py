"""A sequence of the KITTI odometry layout as a frame source (times from times.txt, GT when present)."""

from __future__ import annotations

from collections.abc import Iterator
from functools import cached_property

import numpy as np

from flowvo.camera import Camera, CameraIntrinsics
from flowvo.kitti.sequence import KittiSequence
from flowvo.trajectory import Trajectory


class KittiFolderSource:
    """Frames ``image_0`` of ``ROOT/sequences/NAME`` with the camera of its calib.txt (P0, and the optional
    distortion and camera height lines)."""

    stamps_ns: np.ndarray | None = None  # times.txt holds seconds

    def __init__(self, sequence: KittiSequence) -> None:
        self.sequence = sequence
        self.name = sequence.sequence
        self.image_size_hw = sequence.image_size_hw
        self.frame_count: int | None = len(sequence)
        self.is_synthetic = sequence.is_synthetic
        self.warnings: list[str] = []
        sequence.require_frames(2, "odometry")

    @cached_property
    def camera(self) -> Camera:
        """From the sequence's calib.txt."""
        calibration = self.sequence.calibration
        return Camera(CameraIntrinsics.from_matrix(calibration.K0), calibration.distortion,
                      calibration.camera_height_m, "kitti", calibration.camera_pitch_deg or 0.0,
                      roll_deg=calibration.camera_roll_deg or 0.0, readout_ms=calibration.readout_ms or 0.0)

    @property
    def camera_height_m(self) -> float | None:
        """From the sequence's calib.txt, when it has the line."""
        return self.camera.height_m

    @property
    def camera_pitch_deg(self) -> float | None:
        """From the sequence's calib.txt, when it has the line."""
        return self.sequence.calibration.camera_pitch_deg

    @property
    def camera_roll_deg(self) -> float | None:
        """From the sequence's calib.txt, when it has the line."""
        return self.sequence.calibration.camera_roll_deg

    @cached_property
    def ground_truth(self) -> Trajectory | None:
        """``ROOT/poses/NAME.txt`` when it exists."""
        return self.sequence.poses if self.sequence.has_poses else None

    def frames(self) -> Iterator[tuple[float, np.ndarray]]:
        """(times.txt seconds, grey frame) in order."""
        for index in range(len(self.sequence)):
            yield float(self.sequence.times_s[index]), self.sequence.read_image(index)
