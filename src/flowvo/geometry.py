"""Pose geometry: relative motions, the planar (distance, heading) targets, chaining, SO(3)/SE(3) maps.

Frames: KITTI camera frame, x right, y down, z forward. Poses are camera-to-world ``T_world_cam`` (4x4).
Units: metres and radians. The ground plane is the camera x-z plane; heading (yaw) is the rotation about
the camera y axis, ``yaw = atan2(R[0, 2], R[0, 0])``, positive when turning right (towards +x).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

# The mirroring rule (one source of truth): reflecting the scene left-right maps a motion T to S T S.
MIRROR_X = np.diag([-1.0, 1.0, 1.0, 1.0])


def wrap_angle_rad(angle_rad: np.ndarray | float) -> np.ndarray:
    """Wrap angles to (-pi, pi]."""
    wrapped = np.mod(np.asarray(angle_rad, dtype=np.float64) + np.pi, 2.0 * np.pi) - np.pi
    return np.where(wrapped == -np.pi, np.pi, wrapped)


def invert_se3(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms (..., 4, 4) using R^T."""
    R = T[..., :3, :3]
    t = T[..., :3, 3:]
    inverse = np.zeros_like(T)
    Rt = np.swapaxes(R, -1, -2)
    inverse[..., :3, :3] = Rt
    inverse[..., :3, 3:] = -Rt @ t
    inverse[..., 3, 3] = 1.0
    return inverse


def rotation_angle_between_rad(R_a: np.ndarray, R_b: np.ndarray) -> np.ndarray:
    """Angle (rad) of the rotation between ``R_a`` and ``R_b`` (..., 3, 3), i.e. of ``R_a^T R_b``.

    Computed from the chord, ``2 asin(||R_a - R_b||_F / sqrt(8))`` (as ``||R_a - R_b||_F = 2 sqrt(2)
    sin(theta / 2)``): exactly 0 for identical rotations and accurate for small angles, where
    ``acos((trace - 1) / 2)`` of a cosine rounded near 1 floors at ~1e-8 rad (~3e-4 rad in float32).
    """
    chord = np.linalg.norm(R_a - R_b, axis=(-2, -1))
    return 2.0 * np.arcsin(np.minimum(chord / np.sqrt(8.0), 1.0))


def relative_motions(T_world_cam: np.ndarray) -> np.ndarray:
    """Motions between consecutive poses, ``T_{i-1}^{-1} T_i`` (N-1, 4, 4), in the camera frame of i-1."""
    return invert_se3(T_world_cam[:-1]) @ T_world_cam[1:]


def yaw_rad(T_world_cam: np.ndarray) -> np.ndarray:
    """Heading about the camera y axis, ``atan2(R[0,2], R[0,0])``, radians, for poses (..., 4, 4)."""
    return np.arctan2(T_world_cam[..., 0, 2], T_world_cam[..., 0, 0])


def planar_targets(T_world_cam: np.ndarray) -> np.ndarray:
    """The reference system's targets (N-1, 2): distance travelled d_i (m) and heading change (rad).

    ``d_i = ||t_i - t_{i-1}||`` (3-D distance), ``dtheta_i = wrap(yaw_i - yaw_{i-1})`` in (-pi, pi].
    """
    distance_m = np.linalg.norm(np.diff(T_world_cam[:, :3, 3], axis=0), axis=1)
    dyaw_rad = wrap_angle_rad(np.diff(yaw_rad(T_world_cam)))
    return np.stack([distance_m, dyaw_rad], axis=1)


def yaw_rotation(yaw: np.ndarray) -> np.ndarray:
    """Rotations (..., 3, 3) about the camera y axis by ``yaw`` radians (R[0,2] = sin(yaw))."""
    c, s = np.cos(yaw), np.sin(yaw)
    zero, one = np.zeros_like(c), np.ones_like(c)
    return np.stack(
        [np.stack([c, zero, s], -1), np.stack([zero, one, zero], -1), np.stack([-s, zero, c], -1)], -2
    )


def chain_planar(targets: np.ndarray, T_world_start: np.ndarray | None = None) -> np.ndarray:
    """Integrate planar motions (N, 2) = (distance m, heading change rad) into N+1 KITTI poses (N+1, 4, 4).

    Each step moves ``d_i`` along the mean heading of the step, ``yaw_{i-1} + dtheta_i / 2`` (the chord of
    a constant-curvature arc), in the x-z plane; no elevation, roll or pitch. The start pose (default
    identity) contributes its position and yaw only.
    """
    start = np.eye(4) if T_world_start is None else T_world_start
    yaw0 = float(yaw_rad(start))
    dyaw = targets[:, 1]
    yaws = yaw0 + np.concatenate([[0.0], np.cumsum(dyaw)])
    mid_yaw = yaws[:-1] + dyaw / 2.0
    steps = np.stack([targets[:, 0] * np.sin(mid_yaw), np.zeros_like(mid_yaw), targets[:, 0] * np.cos(mid_yaw)], 1)
    positions = start[:3, 3] + np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])
    positions[:, 1] = start[1, 3]
    poses = np.tile(np.eye(4), (len(yaws), 1, 1))
    poses[:, :3, :3] = yaw_rotation(yaws)
    poses[:, :3, 3] = positions
    return poses


def chain_se3(motions: np.ndarray, T_world_start: np.ndarray | None = None) -> np.ndarray:
    """Compose relative motions (N, 4, 4) into N+1 poses: ``T_i = T_{i-1} M_i``."""
    poses = np.empty((len(motions) + 1, 4, 4))
    poses[0] = np.eye(4) if T_world_start is None else T_world_start
    for i, motion in enumerate(motions):
        poses[i + 1] = poses[i] @ motion
    return poses


def skew(vector: np.ndarray) -> np.ndarray:
    """The 3x3 matrix of the cross product with ``vector`` (3,): ``skew(a) @ b == np.cross(a, b)``."""
    x, y, z = vector
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross products of 3-vectors along the last axis of ``a`` and ``b`` (broadcast): the same products and
    differences as ``np.cross`` (identical results) without its axis handling, which cost 40 us a call in the
    stream against 10."""
    a, b = np.asarray(a), np.asarray(b)
    product = np.empty(np.broadcast_shapes(a.shape, b.shape), np.result_type(a, b))
    product[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    product[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    product[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return product


def so3_exp(rotvec: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from axis-angle vectors (..., 3), radians."""
    rotvec = np.asarray(rotvec, dtype=np.float64)
    return Rotation.from_rotvec(rotvec.reshape(-1, 3)).as_matrix().reshape(*rotvec.shape[:-1], 3, 3)


def so3_log(rotation: np.ndarray) -> np.ndarray:
    """Axis-angle vectors (..., 3), radians (angle in [0, pi]), of rotations (..., 3, 3).

    Up to 90 degrees from the matrix's antisymmetric part, ``sin(angle) axis``, and its trace (the stream takes
    one a step: SciPy's ``Rotation`` took 0.23 ms a call there, this 0.05); beyond, where that part vanishes
    towards 180 degrees, by SciPy's quaternion."""
    R = np.asarray(rotation, dtype=np.float64)
    sine_axis = 0.5 * np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]],
                               axis=-1)
    sine = np.sqrt((sine_axis * sine_axis).sum(axis=-1))
    cosine = 0.5 * (R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1.0)
    angle = np.arctan2(sine, cosine)
    log = sine_axis * np.where(sine > 0.0, angle / np.where(sine > 0.0, sine, 1.0), 1.0)[..., None]
    wide = cosine < 0.0
    if wide.any():
        log[wide] = Rotation.from_matrix(R[wide]).as_rotvec()
    return log


def se3_targets(motions: np.ndarray) -> np.ndarray:
    """6-DoF targets (N, 6) of relative motions: translation (m, camera frame of i-1) then axis-angle (rad)."""
    return np.concatenate([motions[:, :3, 3], so3_log(motions[:, :3, :3])], axis=1)


def se3_from_targets(targets: np.ndarray) -> np.ndarray:
    """Relative motions (N, 4, 4) from 6-DoF targets (N, 6) as produced by :func:`se3_targets`."""
    motions = np.tile(np.eye(4), (len(targets), 1, 1))
    motions[:, :3, :3] = so3_exp(targets[:, 3:])
    motions[:, :3, 3] = targets[:, :3]
    return motions


TARGET_NAMES = {  # the components of each head's targets, in order, with their units
    "planar": ("distance_m", "heading_rad"),  # heading_rad: the heading change over the step
    "se3": ("tx_m", "ty_m", "tz_m", "rx_rad", "ry_rad", "rz_rad"),  # camera frame of frame i-1
}


def mirror_targets(targets: np.ndarray, head: str) -> np.ndarray:
    """Mirror regression targets: planar negates the heading change; se3 negates tx, ry and rz."""
    signs = {"planar": np.array([1.0, -1.0]), "se3": np.array([-1.0, 1.0, 1.0, 1.0, -1.0, -1.0])}[head]
    return targets * signs
