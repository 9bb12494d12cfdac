"""KITTI and TUM pose files.

KITTI pose file: one line per frame, the 3x4 camera-to-world matrix [R | t] row-major (12 floats).
Frame-indexed form (used by some evaluation tools): ``frame_index`` followed by the 12 floats; frames may
be missing. A missing frame is simply absent from the returned :class:`Trajectory`; the metric then skips
every segment whose first or last frame is missing (as the widely used Python port of the devkit does).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from flowvo.errors import FlowvoError
from flowvo.io.atomic import atomic_open
from flowvo.io.text_numbers import parse_float
from flowvo.trajectory import Trajectory

_ORTHONORMAL_TOLERANCE = 1e-2
MAX_FRAME_INDEX = 2**31
MAX_TRANSLATION_M = 1e8  # beyond UTM and Earth-centred coordinates; squares stay far from overflow


def _numbers(fields: list[str], path: Path, line_number: int) -> list[float]:
    """The 12 or 13 numbers of one line; raises naming the line."""
    try:
        values = [parse_float(field) for field in fields]
    except ValueError:
        raise FlowvoError("expected 12 numbers (or frame index + 12), found text", path, line_number) from None
    if len(values) not in (12, 13):
        raise FlowvoError(f"expected 12 numbers (or frame index + 12), found {len(values)}", path, line_number)
    return values


def _pose(values: list[float], path: Path, line_number: int) -> np.ndarray:
    """The 4x4 pose of 12 row-major numbers, checked to be finite with a proper rotation."""
    pose = np.eye(4)
    pose[:3, :4] = np.reshape(values, (3, 4))
    if not np.all(np.isfinite(pose)):
        raise FlowvoError("pose contains NaN or infinity", path, line_number)
    if np.abs(pose[:3, 3]).max() > MAX_TRANSLATION_M:
        raise FlowvoError(f"translation beyond {MAX_TRANSLATION_M:.0e} m (wrong units or a damaged file?)", path,
                          line_number)
    rotation = pose[:3, :3]
    if np.abs(rotation @ rotation.T - np.eye(3)).max() > _ORTHONORMAL_TOLERANCE:
        raise FlowvoError("rotation part is not orthonormal", path, line_number)
    if np.linalg.det(rotation) < 0:
        raise FlowvoError("rotation part has determinant -1: a reflection, not a rotation", path, line_number)
    return pose


def read_kitti_poses(path: str | Path) -> Trajectory:
    """Read a KITTI pose file in the 12-float or the frame-indexed 13-number form.

    Every line is checked: numbers only, finite, translations within 1e8 m, a proper rotation (orthonormal
    to 1e-2, determinant +1), frame indices non-negative integers increasing; a binary file is refused.
    """
    path = Path(path)
    if not path.is_file():
        raise FlowvoError("pose file not found" if not path.exists() else "is not a file", path)
    try:
        with open(path, encoding="utf-8-sig") as handle:  # -sig: a byte-order mark is not a number
            lines = handle.readlines()
    except UnicodeDecodeError:
        raise FlowvoError("not a text pose file (binary data or not UTF-8)", path) from None
    frame_ids: list[int] = []
    matrices: list[np.ndarray] = []
    indexed: bool | None = None
    for line_number, line in enumerate(lines, start=1):
        fields = line.split()
        if not fields:
            continue
        values = _numbers(fields, path, line_number)
        line_indexed = len(values) == 13
        if indexed is None:
            indexed = line_indexed
        elif indexed != line_indexed:
            raise FlowvoError("mixes 12-number and frame-indexed 13-number lines", path, line_number)
        if not line_indexed:
            frame_id = len(frame_ids)
        elif not values[0].is_integer() or not 0 <= values[0] < MAX_FRAME_INDEX:
            raise FlowvoError(f"frame index {fields[0]} is not an integer in 0..{MAX_FRAME_INDEX - 1}", path,
                              line_number)
        else:
            frame_id = int(values[0])
            if frame_ids and frame_id <= frame_ids[-1]:
                raise FlowvoError(f"frame index {frame_id} is not increasing", path, line_number)
        matrices.append(_pose(values[-12:], path, line_number))
        frame_ids.append(frame_id)
    if not matrices:
        raise FlowvoError("pose file is empty", path)
    return Trajectory(np.asarray(frame_ids, dtype=np.int64), np.stack(matrices))


def format_kitti_poses(trajectory: Trajectory, with_frame_index: bool = False) -> str:
    """KITTI pose text, 12 floats per line (optionally preceded by the frame index)."""
    lines = []
    for frame_id, pose in zip(trajectory.frame_ids, trajectory.T_world_cam, strict=True):
        numbers = " ".join(f"{value:.9e}" for value in pose[:3, :4].reshape(-1))
        lines.append(f"{frame_id} {numbers}" if with_frame_index else numbers)
    return "\n".join(lines) + "\n"


def write_kitti_poses(path: str | Path, trajectory: Trajectory, with_frame_index: bool | None = None) -> None:
    """Write a KITTI pose file atomically; the frame index is written when frames are missing."""
    if with_frame_index is None:
        with_frame_index = not trajectory.is_complete
    with atomic_open(path) as handle:
        handle.write(format_kitti_poses(trajectory, with_frame_index))


def rotation_to_quaternion_xyzw(rotation: np.ndarray) -> np.ndarray:
    """Unit quaternion (qx, qy, qz, qw), qw >= 0, of a 3x3 rotation matrix."""
    quaternion = Rotation.from_matrix(rotation).as_quat()
    return -quaternion if quaternion[3] < 0 else quaternion


def write_tum_trajectory(path: str | Path, trajectory: Trajectory, timestamps_s: np.ndarray) -> None:
    """Write TUM format ``timestamp tx ty tz qx qy qz qw`` atomically.

    ``timestamps_s`` (N,): one time in seconds per pose of ``trajectory`` (for a KITTI sequence, its
    times.txt entries of the trajectory's frames), so tools such as evo associate poses by real time.
    """
    timestamps_s = np.asarray(timestamps_s, dtype=np.float64)
    if timestamps_s.shape != (len(trajectory),) or not np.all(np.isfinite(timestamps_s)):
        raise ValueError(f"need one finite timestamp per pose: {len(trajectory)} poses, timestamps "
                         f"{timestamps_s.shape}")
    lines = []
    for time_s, pose in zip(timestamps_s, trajectory.T_world_cam, strict=True):
        q = rotation_to_quaternion_xyzw(pose[:3, :3])
        t = pose[:3, 3]
        lines.append(
            f"{time_s:.9f} {t[0]:.9f} {t[1]:.9f} {t[2]:.9f} "
            f"{q[0]:.9f} {q[1]:.9f} {q[2]:.9f} {q[3]:.9f}"
        )
    with atomic_open(path) as handle:
        handle.write("\n".join(lines) + "\n")
