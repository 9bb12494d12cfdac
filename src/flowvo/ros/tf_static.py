"""The camera's height above the ground and its mounting (pitch, roll) from a bag's static transforms
(``/tf_static``, tf2_msgs/TFMessage).

ROS names the ground under a robot or car ``base_footprint`` (REP 105: the base's projection on the ground,
z up); the image messages name their optical frame in ``header.frame_id``. The height is the z of the
camera frame's origin in the ground frame, through the chain of static transforms between them; the pitch
is how far the optical axis (the optical frame's z) points below the ground's plane, and the roll how far the
camera is then turned about it (right side down positive, :func:`flowvo.camera.mounting_rotation`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from flowvo.camera import mounting_of_road_normal

GROUND_FRAME = "base_footprint"


@dataclass(frozen=True)
class StaticTransform:
    """``child`` in ``parent``: translation (m) and rotation quaternion (x, y, z, w) of the child frame."""

    parent: str
    child: str
    translation_m: tuple[float, float, float]
    rotation_xyzw: tuple[float, float, float, float]

    def matrix(self) -> np.ndarray:
        """The 4x4 pose of the child frame in the parent frame."""
        T = np.eye(4)
        T[:3, :3] = Rotation.from_quat(self.rotation_xyzw).as_matrix()
        T[:3, 3] = self.translation_m
        return T


def frame_in(transforms: list[StaticTransform], frame: str, reference: str) -> np.ndarray | None:
    """The 4x4 pose of ``frame`` in ``reference`` through the tree of ``transforms``, or None when they are
    not connected."""
    edges: dict[str, list[tuple[str, np.ndarray]]] = {}
    for transform in transforms:
        T = transform.matrix()
        edges.setdefault(transform.parent, []).append((transform.child, T))
        edges.setdefault(transform.child, []).append((transform.parent, np.linalg.inv(T)))
    poses, todo = {reference: np.eye(4)}, [reference]
    while todo:
        current = todo.pop()
        for neighbour, T in edges.get(current, []):
            if neighbour not in poses:
                poses[neighbour] = poses[current] @ T
                todo.append(neighbour)
    return poses.get(frame)


def camera_height_m(transforms: list[StaticTransform], camera_frame: str, ground_frame: str = GROUND_FRAME
                    ) -> float | None:
    """Height (m) of ``camera_frame``'s origin above ``ground_frame`` (z up), or None when the static
    transforms do not connect them or put the camera at or below the ground."""
    pose = frame_in(transforms, camera_frame, ground_frame)
    if pose is None or not pose[2, 3] > 0:
        return None
    return float(pose[2, 3])


def camera_mounting_deg(transforms: list[StaticTransform], camera_frame: str, ground_frame: str = GROUND_FRAME
                        ) -> tuple[float, float] | None:
    """The pitch of ``camera_frame``'s optical axis (z) below ``ground_frame``'s plane and its roll about it after
    the pitch (degrees, down and right side down positive), or None when the static transforms do not connect
    them."""
    pose = frame_in(transforms, camera_frame, ground_frame)
    return None if pose is None else mounting_of_road_normal(-pose[2, :3])  # the ground's down axis, camera frame
