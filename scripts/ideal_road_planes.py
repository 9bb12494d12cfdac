"""How the road's normal and distance (:class:`flowvo.odometry.road_normal.RoadNormal`) fare on a drive's real road
profile with perfect measurements (a markdown table).

For each pose file, the synthetic renderer's road is built along the drive (:func:`flowvo.synth.world.build_world`:
the road follows the path's heights, the camera rides 1.65 m above it) and each step fits a plane to the road's
points straight ahead of the previous frame's camera, 6-30 m out on rows evenly spaced in the image (KITTI's camera;
``--nearest-m``: from farther out, as a camera pitched up or over a bonnet sees it), scaled by the true step. The
road's normal is carried by the true rotations and the step's length is the camera height over the plane's distance,
taken along the blend and under the car. No flow, no noise, no RANSAC: what is left is the model's own error on that
road (its grade changes, the car's pitching). Steps under 0.3 m fit no plane. Columns: the root mean square of the
path over the true one per stretch of ``--stretch`` steps (%), and the whole path's (%).

Usage: python scripts/ideal_road_planes.py POSES.txt [POSES.txt ...] [--frames 1500] [--stretch 50] [--nearest-m M]
(KITTI pose files, e.g. the ground truth ``poses/00.txt`` .. ``10.txt``; 0.1 s a frame.)
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from flowvo.camera import KITTI_CAMERA_HEIGHT_M
from flowvo.kitti.poses import read_kitti_poses
from flowvo.odometry.road_normal import RoadNormal
from flowvo.odometry.road_plane import fit_road_plane
from flowvo.synth.world import World, build_world

FOCAL_PX = 359.0  # the working width's focal length of KITTI's camera
ROWS_BELOW_HORIZON_PX = np.arange(20.0, 100.0, 4.0)  # the road grid's rows: 30 m to 6 m ahead (KITTI's camera)
MIN_STEP_M = 0.3
DT_S = 0.1


def road_points_ahead(world: World, T_world_cam: np.ndarray, nearest_m: float) -> np.ndarray:
    """The road's points (world, metres) straight ahead of a camera, level: on the grid's rows from ``nearest_m``
    ahead on, up to 3.5 m aside."""
    centre, forward = T_world_cam[:3, 3], T_world_cam[:3, 2].copy()
    forward[1] = 0.0
    forward /= np.linalg.norm(forward)
    right = np.array([forward[2], 0.0, -forward[0]])
    depths = FOCAL_PX * KITTI_CAMERA_HEIGHT_M / ROWS_BELOW_HORIZON_PX
    depth, share = np.meshgrid(depths[depths >= nearest_m], np.linspace(-1.0, 1.0, 9))
    aside = share * np.minimum(depth * 100.0 / FOCAL_PX, 3.5)
    x = (centre[0] + forward[0] * depth + right[0] * aside).ravel()
    z = (centre[2] + forward[2] * depth + right[2] * aside).ravel()
    col, row = world.grid_coords(x, z)
    y = cv2.remap(world.ground_y.astype(np.float32), col[None], row[None], cv2.INTER_LINEAR)[0]
    return np.stack([x, y, z], axis=1)


def length_ratios(T_world_cam: np.ndarray, under_the_car: bool, nearest_m: float = 0.0
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Each step's length from the road over the true one (NaN where no plane was fitted), and the true steps (m)."""
    world = build_world(T_world_cam, seed=0)
    steps_m = np.linalg.norm(np.diff(T_world_cam[:, :3, 3], axis=0), axis=1)
    road, ratios = RoadNormal(), np.full(len(steps_m), np.nan)
    for i, step_m in enumerate(steps_m):
        key, current = T_world_cam[i], T_world_cam[i + 1]
        R_current_key = current[:3, :3].T @ key[:3, :3]
        road.advance(R_current_key, DT_S, step_m)
        if step_m < MIN_STEP_M:
            continue
        points = (road_points_ahead(world, key, nearest_m) - key[:3, 3]) @ key[:3, :3] / step_m
        plane = fit_road_plane(points, inlier_fraction_of_height=1.0)
        if plane is None:
            continue
        height_m = KITTI_CAMERA_HEIGHT_M if under_the_car else None
        smoothed = road.smoothed(plane, R_current_key, camera_height_m=height_m)
        ratios[i] = KITTI_CAMERA_HEIGHT_M / smoothed.distance / step_m
    return ratios, steps_m


def stretch_rms_percent(ratios: np.ndarray, steps_m: np.ndarray, stretch: int) -> float:
    """The root mean square over stretches of ``stretch`` steps of their path over the true one, minus 1 (%)."""
    errors = []
    for start in range(0, len(steps_m) - stretch + 1, stretch):
        measured = ~np.isnan(ratios[start:start + stretch])
        if measured.any():
            true = steps_m[start:start + stretch][measured]
            errors.append(np.sum(ratios[start:start + stretch][measured] * true) / np.sum(true) - 1.0)
    return 100.0 * float(np.sqrt(np.mean(np.square(errors))))


def path_percent(ratios: np.ndarray, steps_m: np.ndarray) -> float:
    """The whole path over the true one, minus 1 (%), over the steps with a plane."""
    measured = ~np.isnan(ratios)
    return 100.0 * float(np.sum(ratios[measured] * steps_m[measured]) / np.sum(steps_m[measured]) - 1.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("poses", nargs="+", type=Path)
    parser.add_argument("--frames", type=int, default=1500, help="the first frames of each drive")
    parser.add_argument("--stretch", type=int, default=50, help="steps per stretch")
    parser.add_argument("--nearest-m", type=float, default=0.0,
                        help="the nearest road fitted, metres ahead (default: the grid's 6 m; 10: a camera pitched 5 "
                             "degrees up)")
    args = parser.parse_args()
    print("| drive | stretches, along the blend | stretches, under the car | path, along the blend "
          "| path, under the car |")
    print("| --- | --- | --- | --- | --- |")
    for path in args.poses:
        T_world_cam = read_kitti_poses(path).T_world_cam[: args.frames]
        blend = length_ratios(T_world_cam, under_the_car=False, nearest_m=args.nearest_m)
        under = length_ratios(T_world_cam, under_the_car=True, nearest_m=args.nearest_m)
        print(f"| {path.name} | {stretch_rms_percent(*blend, args.stretch):.2f} % | "
              f"{stretch_rms_percent(*under, args.stretch):.2f} % | {path_percent(*blend):+.2f} % | "
              f"{path_percent(*under):+.2f} % |")


if __name__ == "__main__":
    main()
