"""Sample a 10 Hz camera path at another frame rate: the same drive (places and speeds), more or fewer frames.

Positions follow a monotone cubic (PCHIP: no overshoot, so a parked car stays parked) and orientations
a spherical linear interpolation, both over time. Frames that fall on a path sample are that sample
exactly, so a 30 fps render's every third frame is the 10 fps render's frame.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.spatial.transform import Rotation, Slerp


def frames_spanning(path_frames: int, path_rate_hz: float, rate_hz: float) -> int:
    """How many frames at ``rate_hz`` fit in the duration of ``path_frames`` path samples (first to last)."""
    return math.floor((path_frames - 1) * rate_hz / path_rate_hz + 1e-9) + 1


def path_frames_for(frames: int, path_rate_hz: float, rate_hz: float) -> int:
    """How many path samples cover ``frames`` frames at ``rate_hz``."""
    return math.ceil((frames - 1) * path_rate_hz / rate_hz - 1e-9) + 1


def poses_at(T_world_cam: np.ndarray, path_rate_hz: float, times_s: np.ndarray) -> np.ndarray:
    """Poses (T, 4, 4) at ``times_s`` (T,) (seconds from the first sample; the last sample's after it) of a path
    (N, 4, 4) sampled at ``path_rate_hz``."""
    path_times_s = np.arange(len(T_world_cam)) / path_rate_hz
    times_s = np.minimum(times_s, path_times_s[-1])
    out = np.tile(np.eye(4), (len(times_s), 1, 1))
    out[:, :3, 3] = PchipInterpolator(path_times_s, T_world_cam[:, :3, 3], axis=0)(times_s)
    out[:, :3, :3] = Slerp(path_times_s, Rotation.from_matrix(T_world_cam[:, :3, :3]))(times_s).as_matrix()
    return out


def resample_poses(T_world_cam: np.ndarray, path_rate_hz: float, rate_hz: float, frames: int) -> np.ndarray:
    """Poses (frames, 4, 4) at times ``i / rate_hz`` of a path (N, 4, 4) sampled at ``path_rate_hz``."""
    if rate_hz == path_rate_hz and frames <= len(T_world_cam):
        return T_world_cam[:frames].copy()
    out = poses_at(T_world_cam, path_rate_hz, np.arange(frames) / rate_hz)
    ratio = path_rate_hz / rate_hz
    on_sample = np.flatnonzero(np.isclose(np.arange(frames) * ratio, np.round(np.arange(frames) * ratio),
                                          rtol=0.0, atol=1e-9))
    out[on_sample] = T_world_cam[np.round(on_sample * ratio).astype(int)]
    return out
