"""What a drive did, from its poses and timestamps alone (no ground truth): distance, duration, speeds and
the net change of heading.

Frames: ``T_world_cam`` (N, 4, 4), camera-to-world, world = the first camera's frame (x right, y down,
z forward), metres; ``times_s`` (N,) seconds, strictly increasing (any origin).

- ``distance_m``: the path length, the sum of the distances between consecutive camera centres;
- ``duration_s``: last time minus first;
- ``mean_speed_mps``: distance over duration;
- ``top_speed_mps``: the largest mean speed over any stretch of :data:`TOP_SPEED_WINDOW_S` (1 s): the
  distance covered between t and t + 1 s, the camera moving at a constant speed within each step, over 1 s.
  A single long step (a wrong measurement) is averaged with its neighbours instead of reported as a speed.
  A drive shorter than 1 s has one stretch, the whole drive (its mean speed);
- ``heading_change_deg``: the net change of heading about the world's vertical axis (the first camera's y),
  left turns positive: each step's change of the camera's forward axis (z) projected on the first camera's
  x-z plane, wrapped to [-180, 180) degrees, summed; so a full loop counter-clockwise seen from above is
  +360, a left turn then a right turn of the same angle is 0.
"""

from __future__ import annotations

import numpy as np

from flowvo.errors import FlowvoError

TOP_SPEED_WINDOW_S = 1.0  # seconds: top speed is the largest mean speed over a stretch this long


def drive_summary(T_world_cam: np.ndarray, times_s: np.ndarray) -> dict:
    """``{"distance_m", "duration_s", "mean_speed_mps", "top_speed_mps", "heading_change_deg"}`` (floats) of
    the drive whose camera poses are ``T_world_cam`` (N, 4, 4) at ``times_s`` (N,), N >= 2 (see the module
    docstring for each one's definition)."""
    poses = np.asarray(T_world_cam, dtype=np.float64)
    times = np.asarray(times_s, dtype=np.float64)
    if poses.ndim != 3 or poses.shape[1:] != (4, 4) or times.shape != (len(poses),):
        raise FlowvoError(f"a drive summary needs poses (N, 4, 4) and times (N,), got {poses.shape} and {times.shape}")
    if len(poses) < 2:
        raise FlowvoError(f"a drive summary needs at least 2 poses, got {len(poses)}")
    if not (np.all(np.isfinite(poses)) and np.all(np.isfinite(times))):
        raise FlowvoError("a drive summary needs finite poses and times")
    if np.any(np.diff(times) <= 0):
        raise FlowvoError("a drive summary needs strictly increasing times")
    step_m = np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1)
    travelled_m = np.concatenate([[0.0], np.cumsum(step_m)])
    distance, duration = float(travelled_m[-1]), float(times[-1] - times[0])
    return {"distance_m": distance, "duration_s": duration, "mean_speed_mps": distance / duration,
            "top_speed_mps": _top_speed_mps(times, travelled_m, distance / duration),
            "heading_change_deg": _heading_change_deg(poses[:, :3, 2])}


def _top_speed_mps(times: np.ndarray, travelled_m: np.ndarray, mean_speed_mps: float) -> float:
    """The largest distance covered in any :data:`TOP_SPEED_WINDOW_S` stretch, over its length. The distance
    travelled is piecewise linear in time, so the difference over a sliding window is too and is largest
    where the window starts or ends at a frame: only those starts are tried."""
    window = TOP_SPEED_WINDOW_S
    if times[-1] - times[0] <= window:
        return mean_speed_mps
    starts = np.concatenate([times, times - window])
    starts = starts[(starts >= times[0]) & (starts <= times[-1] - window)]
    covered = np.interp(starts + window, times, travelled_m) - np.interp(starts, times, travelled_m)
    return float(covered.max() / window)


def _heading_change_deg(forward: np.ndarray) -> float:
    """The summed signed changes (degrees, left positive) of the heading of the forward axes ``forward``
    (N, 3), world frame (x right, y down, z forward): heading = atan2(-x, z), turning left (towards -x) is
    positive."""
    heading = np.arctan2(-forward[:, 0], forward[:, 2])
    change = np.diff(heading)
    change = (change + np.pi) % (2 * np.pi) - np.pi  # wrapped to [-pi, pi)
    return float(np.degrees(change.sum()))
