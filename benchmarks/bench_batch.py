"""Throughput of ``flowvo batch`` over 8 short real drives with 1 and 2 worker processes (and, with
``--ray auto``, as Ray tasks), and the peak memory of a worker.

The drives: the real KITTI clips (../shared/data/real/kitti_clips; 07 cut into two halves) as KITTI
folders (ground truth re-based to each piece's first frame) and the same four pieces as MPEG-4 videos
(even frame width), listed in a manifest that gives each video its calib.txt: 8 drives, 624 frames.
Every output is written as ``flowvo run`` writes it (evaluation plots included), default method.

Run: python benchmarks/bench_batch.py [--workers 1 2] [--ray auto]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from _table import print_table

from flowvo.batch import discover_drives, run_batch
from flowvo.drive.options import RunOptions
from flowvo.kitti.poses import read_kitti_poses, write_kitti_poses
from flowvo.kitti.sequence import KittiSequence
from flowvo.trajectory import Trajectory

CLIPS = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real" / "kitti_clips"
PIECES = {"01": ("01", 0, 102), "06": ("06", 0, 50), "07a": ("07", 0, 80), "07b": ("07", 80, 160)}
LENGTHS_M = (10.0, 20.0, 30.0, 40.0)  # short drives: the devkit's 100-800 m sub-paths do not fit


def make_drives(folder: Path) -> Path:
    """Write the 4 KITTI pieces and their 4 videos under ``folder``; returns the manifest listing all 8."""
    root = folder / "kitti"
    (root / "poses").mkdir(parents=True)
    (folder / "videos").mkdir()
    lines = ["path,sequence,calib"]
    for name, (clip, first, last) in PIECES.items():
        source = KittiSequence(CLIPS, clip)
        target = root / "sequences" / name
        (target / "image_0").mkdir(parents=True)
        calib = target / "calib.txt"
        calib.write_text((source.directory / "calib.txt").read_text())
        np.savetxt(target / "times.txt", source.times_s[first:last] - source.times_s[first], fmt="%.6e")
        gt = read_kitti_poses(source.pose_path).T_world_cam[first:last]
        write_kitti_poses(root / "poses" / f"{name}.txt",
                          Trajectory.from_poses(np.linalg.inv(gt[0]) @ gt))  # the piece starts at the identity
        frames = [source.read_image(index) for index in range(first, last)]
        for index, frame in enumerate(frames):
            cv2.imwrite(str(target / "image_0" / f"{index:06d}.png"), frame)
        h, w = frames[0].shape
        even_w = w - w % 2  # MPEG-4 needs an even width; cutting the last column keeps the intrinsics
        video = folder / "videos" / f"drive_{name}.mp4"
        writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (even_w, h))
        for frame in frames:
            writer.write(cv2.cvtColor(np.ascontiguousarray(frame[:, :even_w]), cv2.COLOR_GRAY2BGR))
        writer.release()
        lines += [f"{root},{name},", f"{video},,{calib}"]
    manifest = folder / "fleet.csv"
    manifest.write_text("\n".join(lines) + "\n")
    return manifest


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="local worker counts to compare")
    parser.add_argument("--ray", help="also run the batch on Ray (auto, or a cluster address)")
    args = parser.parse_args()
    if not CLIPS.is_dir():
        raise SystemExit(f"real KITTI clips not found at {CLIPS}")
    with tempfile.TemporaryDirectory(prefix="bench_batch_") as temp:
        drives = discover_drives([str(make_drives(Path(temp)))])
        runs = [(f"{workers} local", {"workers": workers}) for workers in args.workers]
        runs += [(f"ray {args.ray}", {"ray": args.ray})] if args.ray else []
        rows, baseline = [], None
        for label, backend in runs:
            start = time.perf_counter()
            lines = run_batch(drives, Path(temp) / label.replace(" ", "_"), RunOptions(out="", lengths_m=LENGTHS_M),
                              **backend)
            wall_s = time.perf_counter() - start
            failed = [line.drive for line in lines if line.status != "ok"]
            if failed:
                raise SystemExit(f"{label}: drives failed: {', '.join(failed)}")
            frames = sum(line.frames for line in lines)
            throughput = frames / wall_s
            baseline = baseline or throughput
            rows.append([label, len(lines), frames, wall_s, throughput, throughput / baseline,
                         max(line.peak_memory_mib for line in lines),
                         statistics.median(line.frames_per_second for line in lines)])
    print_table("flowvo batch: 8 real drives (4 KITTI pieces + the same as MPEG-4), default method",
                ["backend", "drives", "frames", "wall_s", "frames/s", "speed-up", "peak_MiB/worker",
                 "median drive frames/s"], rows)
    print("frames/s: all frames over the batch's wall time (start-up, evaluation, plots included); peak: the "
          "largest resident memory of one worker during one drive.")


if __name__ == "__main__":
    main()
