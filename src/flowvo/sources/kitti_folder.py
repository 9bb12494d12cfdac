"""A sequence of the KITTI odometry layout as a frame source (times from times.txt, GT when present)."""

from __future__ import annotations

from collections.abc import Iterator
from functools import cached_property

import numpy as np

from flowvo.camera import CameraIntrinsics
from flowvo.kitti.sequence import KittiSequence
from flowvo.trajectory import Trajectory


class KittiFolderSource:
    """Frames ``image_0`` of ``ROOT/sequences/NAME`` with the intrinsics of its calib.txt (P0)."""

    def __init__(self, sequence: KittiSequence) -> None:
        self.sequence = sequence
        self.name = sequence.sequence
        self.image_size_hw = sequence.image_size_hw
        self.frame_count: int | None = len(sequence)
        self.is_synthetic = sequence.is_synthetic
        sequence.require_frames(2, "odometry")

    @cached_property
    def intrinsics(self) -> CameraIntrinsics:
        """From P0 of the sequence's calib.txt."""
        return CameraIntrinsics.from_matrix(self.sequence.calibration.K0)

    @cached_property
    def ground_truth(self) -> Trajectory | None:
        """``ROOT/poses/NAME.txt`` when it exists."""
        return self.sequence.poses if self.sequence.has_poses else None

    def frames(self) -> Iterator[tuple[float, np.ndarray]]:
        """(times.txt seconds, grey frame) in order."""
        for index in range(len(self.sequence)):
            yield float(self.sequence.times_s[index]), self.sequence.read_image(index)
