"""What the real-clip scripts share: the clips with the sub-path lengths each is scored on, and one run of
``flowvo run`` on a clip reduced to its table cell."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

from flowvo.kitti.poses import read_kitti_poses
from flowvo.metrics.kitti_odometry import trajectory_distances

# clip -> sub-path lengths (m): 01 fits the devkit's 100 m, 06 and 07 are shorter than 100 m
CLIPS = {"01": ["100"], "06": ["10", "20", "30", "40", "50"], "07": ["10", "20", "30", "40", "50"]}
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
