"""A trajectory: camera-to-world poses with the frame index of each pose (frames may be missing); the least time
between two frames (seconds)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MIN_FRAME_INTERVAL_S = 1e-4  # 10,000 frames/s, beyond any camera to drive with: frames closer are a broken
# clock or seconds taken for another unit, and their times collapse in the TUM file's 9 decimals (from 1970)


@dataclass(frozen=True)
class Trajectory:
    """Poses ``T_world_cam`` (N, 4, 4) of frames ``frame_ids`` (N,), strictly increasing.

    KITTI convention: camera frame x right, y down, z forward; world = camera frame of the first frame;
    translations in metres; 10 frames per second.
    """

    frame_ids: np.ndarray
    T_world_cam: np.ndarray

    def __post_init__(self) -> None:
        if self.T_world_cam.ndim != 3 or self.T_world_cam.shape[1:] != (4, 4):
            raise ValueError(f"T_world_cam must be (N, 4, 4), got {self.T_world_cam.shape}")
        if self.frame_ids.shape != (len(self.T_world_cam),):
            raise ValueError("frame_ids must have one entry per pose")
        if len(self.frame_ids) > 1 and np.any(np.diff(self.frame_ids) <= 0):
            raise ValueError("frame_ids must be strictly increasing")

    @classmethod
    def from_poses(cls, T_world_cam: np.ndarray) -> Trajectory:
        """A complete trajectory whose i-th pose belongs to frame i."""
        return cls(np.arange(len(T_world_cam)), np.asarray(T_world_cam, dtype=np.float64))

    def __len__(self) -> int:
        return len(self.frame_ids)

    @property
    def positions(self) -> np.ndarray:
        """Camera centres in the world frame, (N, 3) metres."""
        return self.T_world_cam[:, :3, 3]

    @property
    def is_complete(self) -> bool:
        """True when the frames are 0..N-1 with none missing."""
        return bool(len(self) == 0 or (self.frame_ids[0] == 0 and self.frame_ids[-1] == len(self) - 1))

    def subset(self, frame_ids: np.ndarray) -> Trajectory:
        """The poses of the given frames (all of which must be present)."""
        index = np.searchsorted(self.frame_ids, frame_ids)
        if np.any(index >= len(self)) or np.any(self.frame_ids[np.minimum(index, len(self) - 1)] != frame_ids):
            raise KeyError("some requested frames are not in the trajectory")
        return Trajectory(np.asarray(frame_ids), self.T_world_cam[index])


def common_frames(a: Trajectory, b: Trajectory) -> tuple[Trajectory, Trajectory]:
    """Both trajectories restricted to the frames they share."""
    shared = np.intersect1d(a.frame_ids, b.frame_ids)
    return a.subset(shared), b.subset(shared)
