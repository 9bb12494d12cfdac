"""Print how the default method's translation directions and the ground truth's lie against the road
plane measured in the same frames: a car moves along the road it stands on, so a direction that dips into
or rises out of the road tells which of the two disagrees with the images.

Per step whose road flow starts at the previous frame and gives a trusted road plane (the plane as fitted,
before the carried normal is blended in): the angle between the step's direction (previous camera frame)
and the plane, for the default method's essential fit and for the ground truth's step, and the difference
of their elevations. Cells: medians over the steps, degrees (angle positive towards the road, elevation
positive up).

Usage: python scripts/direction_against_road.py [DATA_ROOT SEQUENCE ...]
(default: the three real clips; a generated synthetic drive, say ``OUT/seed_0/data 00`` from
``generated_drives_table.py``, gives the comparison with an exact truth)
"""

import sys
from pathlib import Path

import numpy as np
from clip_runs import CLIPS, DEFAULT_CLIPS_ROOT

from flowvo.drive.options import RunOptions, open_drive
from flowvo.drive.stream import stream_odometry
from flowvo.geometry import invert_se3
from flowvo.methods.flowvo import FlowGeometryStep
from flowvo.odometry.road_scale import trusted_road_plane
from flowvo.odometry.scale_window import ScaleWindow
from flowvo.odometry.two_view import essential_motion

MIN_STEP_M = 0.3  # the truth's direction of shorter steps is dominated by its own noise


class RecordingStep(FlowGeometryStep):
    """The default method, recording each step's direction and its own road plane (previous camera frame)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.records: list[tuple[float, np.ndarray, np.ndarray]] = []  # (time_s, direction, road normal)

    def motion(self, times_s, previous, flow):
        motion = super().motion(times_s, previous, flow)
        if flow.key_prev is None and not np.allclose(motion, np.eye(4)):
            fit = essential_motion(flow.motion_prev, flow.motion_next, self.K, threshold_px=self.threshold_px)
            plane = None if fit is None else trusted_road_plane(flow.road_prev, flow.road_next, self.K, fit,
                                                                 min_parallax_px=self.min_road_parallax_px)
            if plane is not None:
                self.records.append((times_s[1], -fit.R.T @ fit.t_dir, plane.normal))
        return motion


def degrees_from_plane(directions: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Angle (deg) of unit ``directions`` (N, 3) from the planes of unit ``normals`` (N, 3), towards them +."""
    return np.degrees(np.arcsin(np.clip(np.einsum("ij,ij->i", directions, normals), -1.0, 1.0)))


def row(data: Path, sequence: str) -> str:
    drive = open_drive(RunOptions(out="", data=str(data), sequence=sequence))
    source = drive.source
    step = RecordingStep(drive.camera, source.image_size_hw, window=ScaleWindow())
    result = stream_odometry(source.frames(), step, source.frame_count, label=sequence)
    index = {float(t): k for k, t in enumerate(result.timestamps_s)}
    truth = source.ground_truth.T_world_cam
    ours, theirs, normals = [], [], []
    for time_s, direction, normal in step.records:
        k = index[float(time_s)]
        moved = (invert_se3(truth[k - 1]) @ truth[k])[:3, 3]
        if np.linalg.norm(moved) >= MIN_STEP_M:
            ours.append(direction)
            theirs.append(moved / np.linalg.norm(moved))
            normals.append(normal)
    ours, theirs, normals = np.array(ours), np.array(theirs), np.array(normals)
    elevation = np.degrees(np.arcsin(-ours[:, 1]) - np.arcsin(-theirs[:, 1]))  # y points down
    return (f"| {data.name} {sequence} ({len(ours)} steps) | {np.median(degrees_from_plane(ours, normals)):+.2f} | "
            f"{np.median(degrees_from_plane(theirs, normals)):+.2f} | {np.median(elevation):+.2f} |")


def main(drives: list[tuple[Path, str]]) -> None:
    print("| drive | flowvo's direction to its road plane | the truth's direction to that plane | "
          "flowvo's elevation - the truth's |")
    print("| --- | --- | --- | --- |")
    for data, sequence in drives:
        print(row(data, sequence), flush=True)
    print("cells: medians over the steps with a trusted road plane, degrees")


if __name__ == "__main__":
    arguments = sys.argv[1:]
    main([(Path(arguments[i]), arguments[i + 1]) for i in range(0, len(arguments), 2)] if arguments
         else [(DEFAULT_CLIPS_ROOT, clip) for clip in CLIPS])
