"""Print how far a synthetic world's own road is from the plane the camera height assumes: per step of a
sequence rendered with ``flowvo synth --gt-flow``, the default method's road plane (its grid, fit and
gates) from the true flow and the true motion, and the step length it implies (camera height over the
plane's distance) against the true step. With exact flow and motion the method can do no better on that
world: whatever error is left is the world's road, not the method's.

Usage: python scripts/synthetic_road_truth.py DATA_ROOT SEQUENCE [SEQUENCE ...]
(e.g. ``flowvo synth --out DATA --sequences 08 --trajectory KITTI_POSES/08.txt --frames 400 --gt-flow``)
"""

import sys
from pathlib import Path

import cv2
import numpy as np

from flowvo.drive.options import RunOptions, make_step, open_drive
from flowvo.odometry.road_scale import trusted_road_plane
from flowvo.odometry.two_view import EssentialMotion

MIN_STEP_M = 0.05  # the true flow of a standstill has no depth to triangulate


def road_errors(root: Path, sequence: str) -> tuple[np.ndarray, int]:
    """Relative step-length errors (N,) of the trusted planes, and how many planes the gates refused."""
    options = RunOptions(out="", data=str(root), sequence=sequence, method="flowvo-geometry")
    drive = open_drive(options)
    step = make_step(options, drive)
    height, width = drive.source.image_size_hw
    scale = np.array([step.working_hw[1] / width, step.working_hw[0] / height])
    grid = step.road.grid_px
    at_full = (grid / scale).astype(np.float32)
    poses = drive.source.ground_truth.T_world_cam
    flow_dir = root / "sequences" / sequence / "flow_gt"
    errors, refused = [], 0
    for index in range(len(poses) - 1):
        T_next_prev = np.linalg.inv(poses[index + 1]) @ poses[index]
        length_m = float(np.linalg.norm(T_next_prev[:3, 3]))
        if length_m < MIN_STEP_M:
            continue
        flow = np.load(flow_dir / f"{index:06d}.npy")
        moved = cv2.remap(flow, at_full[:, :1], at_full[:, 1:], cv2.INTER_LINEAR).reshape(-1, 2) * scale
        motion = EssentialMotion(T_next_prev[:3, :3], T_next_prev[:3, 3] / length_m, np.ones(1, bool))
        plane = trusted_road_plane(grid, (grid + moved).astype(np.float32), step.K, motion)
        if plane is None:
            refused += 1
            continue
        errors.append(step.camera.camera_height_m / plane.distance / length_m - 1.0)
    return np.array(errors), refused


def main(root: Path, sequences: list[str]) -> None:
    print("| sequence | trusted planes | refused | median error % | 5-95 % | share off by more than 3 % |")
    print("| --- | --- | --- | --- | --- | --- |")
    for sequence in sequences:
        errors, refused = road_errors(root, sequence)
        percent = 100 * errors
        low, high = np.percentile(percent, [5, 95])
        print(f"| {sequence} | {len(errors)} | {refused} | {np.median(percent):+.2f} | {low:+.1f}..{high:+.1f} "
              f"| {100 * np.mean(np.abs(percent) > 3):.0f} % |", flush=True)
    print("errors: the step length the world's road implies (true flow, true motion) against the true step")


if __name__ == "__main__":
    main(Path(sys.argv[1]), sys.argv[2:])
