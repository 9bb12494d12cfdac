"""A drive whose poses are a smooth function of time, to read between frames (the clock offset's tests)."""

import numpy as np

from flowvo.geometry import so3_exp


def swaying_drive(at_frames: np.ndarray) -> np.ndarray:
    """Poses (N, 4, 4) of a car at 8 m/s (10 frames/s) on a road of slow bends, its body swaying in pitch and roll,
    at (possibly fractional) frames ``at_frames``: a smooth function of time."""
    t = np.asarray(at_frames, dtype=float)
    yaw = 0.4 * np.sin(2 * np.pi * t / 120.0)
    pitch = 0.01 * np.sin(2 * np.pi * t / 17.0)
    roll = 0.01 * np.cos(2 * np.pi * t / 23.0)
    poses = np.tile(np.eye(4), (len(t), 1, 1))
    poses[:, :3, :3] = so3_exp(np.stack([np.zeros_like(t), yaw, np.zeros_like(t)], 1)) @ \
        so3_exp(np.stack([pitch, np.zeros_like(t), roll], 1))
    fine = np.linspace(0.0, t.max() + 1.0, 20001)  # the path along the heading, integrated finely
    heading = 0.4 * np.sin(2 * np.pi * fine / 120.0)
    step = np.diff(fine)[0] * 0.8
    x, z = np.cumsum(np.sin(heading)) * step, np.cumsum(np.cos(heading)) * step
    poses[:, 0, 3], poses[:, 2, 3] = np.interp(t, fine, x), np.interp(t, fine, z)
    return poses
