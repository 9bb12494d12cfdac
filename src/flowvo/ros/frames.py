"""flowvo's poses in ROS frames (REP 103 and REP 105): the one place that defines the odom frame.

flowvo's ``T_world_cam`` uses the camera optical frame (x right, y down, z forward) for both the camera and
the world, the world being the optical frame of the first camera. ROS tools expect a parent frame with x
forward, y left, z up, and an ``*_optical`` child frame with x right, y down, z forward. So:

- parent ``odom``: origin at the first camera centre, x forward, y left, z up, i.e. the first camera's
  forward-left-up axes (tilted as the camera was, not gravity-aligned: flowvo knows no gravity);
- child ``camera_optical``: the camera's optical frame, as in flowvo.

``T_odom_cam = T_odom_world @ T_world_cam`` with the constant rotation ``R_FLU_OPTICAL``; at the first frame
this is the usual base_link -> camera optical rotation, quaternion (x, y, z, w) = (-0.5, 0.5, -0.5, 0.5).
"""

from __future__ import annotations

import numpy as np

from flowvo.geometry import relative_motions, so3_log
from flowvo.odometry.covariance import in_parent_axes

# Coordinates in the optical frame (x right, y down, z forward) to forward-left-up: x_flu = z, y_flu = -x, z_flu = -y.
R_FLU_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def odom_poses(T_world_cam: np.ndarray) -> np.ndarray:
    """Camera optical frame to odom frame (forward-left-up at the first camera) transforms, (N, 4, 4), metres."""
    T_odom_world = np.eye(4)
    T_odom_world[:3, :3] = R_FLU_OPTICAL
    return T_odom_world @ np.asarray(T_world_cam, dtype=np.float64)


def camera_twists(timestamps_s: np.ndarray, T_world_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Velocities of the camera at each frame, in its own optical frame (nav_msgs/Odometry's child frame).

    Returns ``linear_mps`` (N, 3) and ``angular_radps`` (N, 3): the motion from frame i-1 to frame i over
    their stamp difference (frame 0 takes the motion from 0 to 1; a single frame has zero velocity). The
    angular velocity is the axis-angle of the relative rotation per second, the linear velocity the camera
    centre's displacement per second, both expressed in the camera frame of frame i.
    """
    count = len(T_world_cam)
    if count < 2:
        return np.zeros((count, 3)), np.zeros((count, 3))
    motions = relative_motions(np.asarray(T_world_cam, dtype=np.float64))  # T_{i-1}^{-1} T_i, frame i-1
    dt_s = np.diff(np.asarray(timestamps_s, dtype=np.float64))[:, None]
    R_rel = motions[:, :3, :3]
    linear = np.einsum("nji,nj->ni", R_rel, motions[:, :3, 3]) / dt_s  # R_rel^T t_rel: displacement in frame i
    angular = so3_log(R_rel) / dt_s  # the rotation axis is the same in frames i-1 and i
    return np.vstack([linear[:1], linear]), np.vstack([angular[:1], angular])


def camera_twist_covariances(timestamps_s: np.ndarray, step_covariance: np.ndarray) -> np.ndarray:
    """Covariances (N, 6, 6) of :func:`camera_twists` (linear then angular, in the camera frame of each
    frame) from the steps' covariances (N - 1, 6, 6; :mod:`flowvo.odometry.covariance`, in the same
    frame): each step's over its duration squared (frame 0 takes the first step's, as its twist does)."""
    dt_s = np.diff(np.asarray(timestamps_s, dtype=np.float64))
    twist = np.asarray(step_covariance, dtype=np.float64) / dt_s[:, None, None] ** 2
    return np.concatenate([twist[:1], twist]) if len(twist) else np.zeros((len(timestamps_s), 6, 6))


def odom_pose_covariances(T_world_cam: np.ndarray, pose_covariance: np.ndarray) -> np.ndarray:
    """Pose covariances (N, 6, 6) each in its camera's frame (:func:`flowvo.odometry.covariance.odometry_covariances`)
    along the odom frame's axes, as nav_msgs/Odometry's pose covariance is read."""
    return in_parent_axes(odom_poses(T_world_cam)[:, :3, :3], pose_covariance)
