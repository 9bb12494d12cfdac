"""The real clips at a lower frame rate: every N-th frame of each clip as a KITTI folder (times and poses
kept), run by the default method, against the clip at its own 10 Hz.

Usage: python scripts/frame_rate_clips.py OUT_DIR [CLIPS_ROOT] [--every 2]
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import numpy as np
from clip_runs import CLIPS, DEFAULT_CLIPS_ROOT, run_cell


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("clips", type=Path, nargs="?",
                        default=DEFAULT_CLIPS_ROOT)
    parser.add_argument("--every", type=int, default=2)
    parser.add_argument("--method", default="flowvo")
    args = parser.parse_args()
    rate = np.round(10 / args.every, 2)
    print(f"| clip | 10 Hz | {rate:g} Hz (every {args.every}. frame) |")
    print("| --- | --- | --- |")
    for clip in CLIPS:
        subsample_clip(args.clips, clip, args.out / "data", args.every)
        method = ["--method", args.method]
        cells = [run_cell(args.clips, clip, args.out / "10hz" / clip, method),
                 run_cell(args.out / "data", clip, args.out / "slow" / clip, method)]
        print(f"| {clip} | " + " | ".join(cells) + " |")
    print("cells: t_err % / r_err deg/m / path length against the truth (01: 100 m sub-paths, 06/07: 10-50 m)")


if __name__ == "__main__":
    main()
