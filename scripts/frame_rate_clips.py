"""The real clips at a lower frame rate: every N-th frame of each clip as a KITTI folder (times and poses
kept), run by the default method, against the clip at its own 10 Hz.

Usage: python scripts/frame_rate_clips.py OUT_DIR [CLIPS_ROOT] [--every 2]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np

from flowvo.kitti.poses import read_kitti_poses
from flowvo.metrics.kitti_odometry import trajectory_distances

CLIPS = {"01": ["100"], "06": ["10", "20", "30", "40", "50"], "07": ["10", "20", "30", "40", "50"]}


def subsample_clip(clips: Path, clip: str, out: Path, every: int) -> None:
    """OUT/sequences/CLIP with every ``every``-th frame, its times and poses."""
    source, target = clips / "sequences" / clip, out / "sequences" / clip
    (target / "image_0").mkdir(parents=True, exist_ok=True)
    (out / "poses").mkdir(exist_ok=True)
    shutil.copy(source / "calib.txt", target / "calib.txt")
    times = (source / "times.txt").read_text().split("\n")
    poses = (clips / "poses" / f"{clip}.txt").read_text().split("\n")
    frames = sorted((source / "image_0").glob("*.png"))[::every]
    for index, frame in enumerate(frames):
        shutil.copy(frame, target / "image_0" / f"{index:06d}.png")
    kept = range(0, len(frames) * every, every)
    (target / "times.txt").write_text("\n".join(times[i] for i in kept) + "\n")
    (out / "poses" / f"{clip}.txt").write_text("\n".join(poses[i] for i in kept) + "\n")


def run_cell(data: Path, clip: str, out: Path, lengths: list[str], method: str) -> str:
    subprocess.run(["flowvo", "-q", "run", "--data", str(data), "--sequence", clip, "--out", str(out), "--force",
                    "--method", method, "--lengths", *lengths], check=True, capture_output=True)
    metrics = json.loads((out / f"eval_{clip}" / "metrics.json").read_text())
    truth = trajectory_distances(read_kitti_poses(data / "poses" / f"{clip}.txt").positions)[-1]
    length = trajectory_distances(read_kitti_poses(out / f"{clip}.txt").positions)[-1]
    return f"{metrics['t_err_percent']:.2f} / {metrics['r_err_deg_per_m']:.4f} / {100 * (length / truth - 1):+.1f} %"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("clips", type=Path, nargs="?",
                        default=Path(__file__).parents[2] / "shared/data/real/kitti_clips")
    parser.add_argument("--every", type=int, default=2)
    parser.add_argument("--method", default="flowvo")
    args = parser.parse_args()
    rate = np.round(10 / args.every, 2)
    print(f"| clip | 10 Hz | {rate:g} Hz (every {args.every}. frame) |")
    print("| --- | --- | --- |")
    for clip, lengths in CLIPS.items():
        subsample_clip(args.clips, clip, args.out / "data", args.every)
        cells = [run_cell(args.clips, clip, args.out / "10hz" / clip, lengths, args.method),
                 run_cell(args.out / "data", clip, args.out / "slow" / clip, lengths, args.method)]
        print(f"| {clip} | " + " | ".join(cells) + " |")
    print("cells: t_err % / r_err deg/m / path length against the truth (01: 100 m sub-paths, 06/07: 10-50 m)")


if __name__ == "__main__":
    main()
