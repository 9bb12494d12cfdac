"""Print how the network's distance and the held speed fare on the steps where the default method asked the
network (no trusted road for a while), by how much the view moved beyond its rotation.

For each drive: the steps ``flowvo``'s ``NAME_steps.csv`` marks as measured by the network; their final
lengths in ``flowvo``'s poses and in ``flowvo-geometry``'s (which keeps the held speed there) against the
ground truth's; and each step's translation parallax: the median motion of the essential fit's inliers
beyond what its rotation explains, at the default method's working resolution, in pixels at 620 px wide.
Rows pool the drives by that parallax: summed absolute errors (metres) and summed lengths against the truth.

Usage: python scripts/network_against_held_speed.py DATA_ROOT SEQUENCE FLOWVO_RUN GEOMETRY_RUN [...]
(groups of four; the runs are the folders ``flowvo run --out`` wrote for that sequence)
"""

import sys
from pathlib import Path

import cv2
import numpy as np

from flowvo.camera import undistort_points
from flowvo.drive.options import RunOptions, open_drive
from flowvo.drive.steps_csv import read_steps_csv
from flowvo.kitti.poses import read_kitti_poses
from flowvo.methods.base import REFERENCE_WIDTH_PX
from flowvo.methods.flowvo import FlowGeometryStep
from flowvo.odometry.two_view import essential_motion, translation_parallax_px

BANDS_PX = ((0.0, 0.5), (0.5, 1.0), (1.0, 2.0), (2.0, np.inf))


def step_lengths(poses_path: Path) -> np.ndarray:
    """Each step's length (N-1,), metres, of a KITTI pose file."""
    T = read_kitti_poses(poses_path).T_world_cam
    return np.linalg.norm((np.linalg.inv(T[:-1]) @ T[1:])[:, :3, 3], axis=1)


def parallax_px(data: str, sequence: str, frames: list[int]) -> np.ndarray:
    """The translation parallax (pixels at the reference width) of the steps ending at ``frames``: each pair's
    tracks as the default method prepares them, and its essential fit."""
    drive = open_drive(RunOptions(out="", data=data, sequence=sequence))
    step = FlowGeometryStep(drive.camera, drive.source.image_size_hw)
    to_reference = REFERENCE_WIDTH_PX / step.working_hw[1]
    images = sorted((Path(data) / "sequences" / sequence / "image_0").glob("*.png"))
    values = []
    for frame in frames:
        step.prepare(cv2.imread(str(images[frame - 1]), cv2.IMREAD_GRAYSCALE))
        current = step.prepare(cv2.imread(str(images[frame]), cv2.IMREAD_GRAYSCALE))
        before_px, after_px = (undistort_points(p, step.K, step.camera.distortion)
                               for p in (current.tracked_prev, current.tracked_next))
        fit = essential_motion(before_px, after_px, step.K, threshold_px=step.threshold_px)
        values.append(np.nan if fit is None else to_reference * float(np.median(
            translation_parallax_px(before_px[fit.inliers], after_px[fit.inliers], step.K, fit.R))))
    return np.asarray(values)


def main(arguments: list[str]) -> None:
    if not arguments or len(arguments) % 4:
        raise SystemExit(__doc__)
    rows = []  # (drive, parallax px, true, network, held) per step
    for index in range(0, len(arguments), 4):
        data, sequence, flowvo_run, geometry_run = arguments[index:index + 4]
        records = read_steps_csv(Path(flowvo_run) / f"{sequence}_steps.csv")
        frames = [frame for frame, record in enumerate(records, start=1) if "network" in record.measured_by]
        truth = step_lengths(Path(data) / "poses" / f"{sequence}.txt")
        network, held = (step_lengths(Path(run) / f"{sequence}.txt") for run in (flowvo_run, geometry_run))
        for frame, parallax in zip(frames, parallax_px(data, sequence, frames), strict=True):
            rows.append((f"{data} {sequence}", parallax, truth[frame - 1], network[frame - 1],
                         held[frame - 1]))
    print("| parallax | steps | absolute error, network | absolute error, held speed | summed length against the "
          "truth, network / held |")
    print("| --- | --- | --- | --- | --- |")
    parallax = np.array([row[1] for row in rows])
    truth, network, held = (np.array([row[k] for row in rows]) for k in (2, 3, 4))
    for low, high in BANDS_PX:
        band = (parallax >= low) & (parallax < high)
        if band.any():
            print(f"| {low:g}-{high:g} px | {band.sum()} | {np.abs(network[band] - truth[band]).sum():.1f} m | "
                  f"{np.abs(held[band] - truth[band]).sum():.1f} m | "
                  f"{100 * (network[band].sum() / truth[band].sum() - 1):+.1f} / "
                  f"{100 * (held[band].sum() / truth[band].sum() - 1):+.1f} % |")
    print("per drive (steps, absolute error network / held, metres):")
    for drive in dict.fromkeys(row[0] for row in rows):
        mine = np.array([row[0] == drive for row in rows])
        print(f"  {drive}: {mine.sum()}, {np.abs(network[mine] - truth[mine]).sum():.1f} / "
              f"{np.abs(held[mine] - truth[mine]).sum():.1f}")


if __name__ == "__main__":
    main(sys.argv[1:])
