"""Rendered calibration boards seen by a camera with known intrinsics and lens distortion.

Each output pixel is traced back through the lens: undistorted to a viewing ray (``flowvo.camera``'s
inverse of the distortion), intersected with the board plane, and the board's texture sampled there
(``cv2.remap``). Rendering at twice the resolution and averaging 2x2 blocks keeps the squares' edges
anti-aliased, so corners lie where the camera model puts them to a small fraction of a pixel.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from flowvo.camera import CameraIntrinsics, LensDistortion, distort_points, undistort_points

SUPERSAMPLE = 2  # rendered pixels per output pixel and axis
BACKGROUND = 90  # grey around the board: darker than its white margin, lighter than its black squares


@dataclass(frozen=True)
class TrueCamera:
    intrinsics: CameraIntrinsics
    distortion: LensDistortion
    size_hw: tuple[int, int]


def viewing_rays(camera: TrueCamera) -> np.ndarray:
    """Normalised rays (h, w, 3), z = 1, through the centres of the supersampled pixels."""
    h, w = (n * SUPERSAMPLE for n in camera.size_hw)
    u, v = np.meshgrid((np.arange(w) + 0.5) / SUPERSAMPLE - 0.5, (np.arange(h) + 0.5) / SUPERSAMPLE - 0.5)
    K = camera.intrinsics.K
    ideal = undistort_points(np.c_[u.ravel(), v.ravel()], K, camera.distortion).astype(np.float64)
    x = (ideal[:, 0] - K[0, 2]) / K[0, 0]
    y = (ideal[:, 1] - K[1, 2]) / K[1, 1]
    return np.stack([x, y, np.ones_like(x)], axis=-1).reshape(h, w, 3)


def render_view(rays: np.ndarray, texture: np.ndarray, texture_px_per_m: float, rotation_xyz_deg: tuple,
                translation_m: tuple) -> np.ndarray:
    """The grey image (H, W) uint8 of ``texture`` (a board whose centre is the plane's origin, x right, y
    down, ``texture_px_per_m``) placed by ``rotation_xyz_deg`` (extrinsic x, y, z angles) and
    ``translation_m`` (its centre in the camera frame)."""
    R = Rotation.from_euler("xyz", rotation_xyz_deg, degrees=True).as_matrix()
    H = np.c_[R[:, :2], translation_m]  # board plane (x, y, 1) -> camera ray
    plane = rays @ np.linalg.inv(H).T
    behind = plane[..., 2] <= 0
    th, tw = texture.shape
    map_x = (plane[..., 0] / plane[..., 2] * texture_px_per_m + (tw - 1) / 2).astype(np.float32)
    map_y = (plane[..., 1] / plane[..., 2] * texture_px_per_m + (th - 1) / 2).astype(np.float32)
    map_x[behind] = -1
    fine = cv2.remap(texture, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=BACKGROUND)
    h, w = fine.shape[0] // SUPERSAMPLE, fine.shape[1] // SUPERSAMPLE
    return cv2.resize(fine, (w, h), interpolation=cv2.INTER_AREA)


def checkerboard_texture(inner_rows: int, inner_cols: int, square_px: int) -> np.ndarray:
    """A checkerboard of (inner_rows + 1) x (inner_cols + 1) squares with a white margin of one square."""
    rows, cols = inner_rows + 1, inner_cols + 1
    cells = (np.add.outer(np.arange(rows), np.arange(cols)) % 2 == 0).astype(np.uint8) * 255
    cells = 255 - cells  # black top-left square
    board = np.kron(cells, np.ones((square_px, square_px), np.uint8))
    return np.pad(board, square_px, constant_values=255)


def charuco_texture(board: cv2.aruco.CharucoBoard, square_px: int) -> np.ndarray:
    """The ChArUco board's own picture (OpenCV's), with a white margin of one square."""
    cols, rows = board.getChessboardSize()
    picture = board.generateImage((cols * square_px, rows * square_px), marginSize=0, borderBits=1)
    return np.pad(picture, square_px, constant_values=255)


def varied_poses(count: int, camera: TrueCamera, board_size_m: tuple[float, float], seed: int = 0,
                 max_tilt_deg: float = 40.0, distance_m: tuple[float, float] = (0.45, 0.8),
                 reach: float = 0.45) -> list[tuple]:
    """``count`` (rotation_xyz_deg, translation_m) poses that show the whole board (its outer corners
    inside the image, 10 px in), tilted up to ``max_tilt_deg`` about x and y, its centre up to ``reach``
    times the distance off the optical axis (sideways; 3/4 of that up and down)."""
    rng = np.random.default_rng(seed)
    h, w = camera.size_hw
    half_w, half_h = board_size_m[0] / 2, board_size_m[1] / 2
    corners = np.array([[-half_w, -half_h, 0], [half_w, -half_h, 0], [half_w, half_h, 0], [-half_w, half_h, 0]])
    poses = []
    while len(poses) < count:
        angles = (rng.uniform(-max_tilt_deg, max_tilt_deg), rng.uniform(-max_tilt_deg, max_tilt_deg),
                  rng.uniform(-20, 20))
        z = rng.uniform(*distance_m)
        t = np.array([rng.uniform(-reach, reach) * z, rng.uniform(-0.75 * reach, 0.75 * reach) * z, z])
        R = Rotation.from_euler("xyz", angles, degrees=True).as_matrix()
        points = corners @ R.T + t
        if np.any(points[:, 2] <= 0.05):
            continue
        ideal = points[:, :2] / points[:, 2:] * [camera.intrinsics.fx, camera.intrinsics.fy] + \
            [camera.intrinsics.cx, camera.intrinsics.cy]
        pixels = distort_points(ideal, camera.intrinsics.K, camera.distortion)
        if np.all((pixels >= 10) & (pixels <= [w - 11, h - 11])):
            poses.append((angles, tuple(t)))
    return poses
