"""What the real-clip scripts share: the clips with the sub-path lengths each is scored on, one run of
``flowvo run`` on a clip reduced to its table cell, and one in-process stream of a per-frame step built
for a clip (for variants the command line does not offer)."""

from __future__ import annotations

import json
import subprocess
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from flowvo.camera import Camera
from flowvo.drive.options import RunOptions, open_drive
from flowvo.drive.stream import stream_odometry, timing_report
from flowvo.kitti.poses import read_kitti_poses
from flowvo.methods.base import OdometryStep
from flowvo.metrics.kitti_odometry import trajectory_distances
from flowvo.report.evaluation import evaluate
from flowvo.trajectory import Trajectory

# clip -> sub-path lengths (m): 03 (the long drive) fits the devkit's 100 and 200 m, 01 its 100 m, 06 and 07 are shorter
CLIPS = {"03": ["100", "200"], "01": ["100"], "06": ["10", "20", "30", "40", "50"],
         "07": ["10", "20", "30", "40", "50"]}
DEFAULT_CLIPS_ROOT = Path(__file__).resolve().parents[2] / "shared/data/real/kitti_clips"


def run_cell(data: Path, clip: str, out: Path, extra: list[str] = ()) -> str:
    """Run flowvo on ``clip`` of the KITTI folder ``data`` (with its ground truth) into ``out``; the cell
    ``t_err % / r_err deg/m / path length against the truth``."""
    subprocess.run(["flowvo", "-q", "run", "--data", str(data), "--sequence", clip, "--out", str(out), "--force",
                    "--lengths", *CLIPS[clip], *extra], check=True, capture_output=True)
    metrics = json.loads((out / f"eval_{clip}" / "metrics.json").read_text())
    truth = trajectory_distances(read_kitti_poses(data / "poses" / f"{clip}.txt").positions)[-1]
    length = trajectory_distances(read_kitti_poses(out / f"{clip}.txt").positions)[-1]
    return f"{metrics['t_err_percent']:.2f} / {metrics['r_err_deg_per_m']:.4f} / {100 * (length / truth - 1):+.1f} %"


@dataclass(frozen=True)
class ClipScore:
    """A stream's result on a clip: t_err (%), r_err (deg/m), its path length over the truth's, frames/s, and the
    window stage's milliseconds per frame (0 without one)."""

    t_err_percent: float
    r_err_deg_per_m: float
    length_ratio: float
    frames_per_second: float
    window_ms: float


def stream_clip(data: Path, clip: str, build: Callable[[Camera, tuple[int, int]], OdometryStep]) -> ClipScore:
    """Stream the step ``build(camera, image_size_hw)`` over ``clip`` of the KITTI folder ``data`` (with its
    ground truth) and score it on the clip's sub-paths."""
    drive = open_drive(RunOptions(out="", data=str(data), sequence=clip))
    source = drive.source
    result = stream_odometry(source.frames(), build(drive.camera, source.image_size_hw), source.frame_count,
                             label=clip)
    predicted = Trajectory.from_poses(result.T_world_cam)
    metrics = evaluate(source.ground_truth, predicted, lengths_m=tuple(float(m) for m in CLIPS[clip])).metrics
    predicted_m, truth_m = (trajectory_distances(t.T_world_cam[:, :3, 3])[-1] for t in (predicted, source.ground_truth))
    timing = timing_report(result)
    return ClipScore(float(metrics["t_err_percent"]), float(metrics["r_err_deg_per_m"]), float(predicted_m / truth_m),
                     float(timing["frames_per_second"]),
                     1e3 * float(timing["seconds_per_frame"].get("window", 0.0)))
