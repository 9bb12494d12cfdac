"""The real clips seen through a wide-angle lens: each clip's frames warped through a known lens distortion
(same intrinsics), run by the default method without and with that distortion, against the clip itself.

Usage: python scripts/distorted_clips_table.py OUT_DIR [CLIPS_ROOT] [--model plumb_bob] [--dist K1 K2 P1 P2]
Writes the warped clips as KITTI folders under OUT_DIR/data (never into the clips) and prints a markdown table.
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import cv2
import numpy as np
from clip_runs import CLIPS, DEFAULT_CLIPS_ROOT, run_cell

from flowvo.camera import CameraIntrinsics, LensDistortion, undistort_points
from flowvo.kitti.calib import read_calibration


def lens_maps(image_hw: tuple[int, int], K: np.ndarray, distortion: LensDistortion) -> tuple[np.ndarray, np.ndarray]:
    """remap maps that render the distorted image: each distorted pixel samples its ideal pinhole pixel."""
    h, w = image_hw
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    ideal = undistort_points(np.stack([xs.ravel(), ys.ravel()], axis=1), K, distortion)
    return ideal[:, 0].reshape(h, w), ideal[:, 1].reshape(h, w)


def warp_clip(clips: Path, clip: str, out: Path, distortion: LensDistortion) -> None:
    """OUT/sequences/CLIP (frames through the lens, the clip's calib.txt and times.txt) and OUT/poses."""
    source = clips / "sequences" / clip
    target = out / "sequences" / clip
    (target / "image_0").mkdir(parents=True, exist_ok=True)
    (out / "poses").mkdir(exist_ok=True)
    shutil.copy(source / "calib.txt", target / "calib.txt")
    shutil.copy(source / "times.txt", target / "times.txt")
    shutil.copy(clips / "poses" / f"{clip}.txt", out / "poses" / f"{clip}.txt")
    K = CameraIntrinsics.from_matrix(read_calibration(source / "calib.txt").K0).K
    maps = None
    for frame in sorted((source / "image_0").glob("*.png")):
        image = cv2.imread(str(frame), cv2.IMREAD_GRAYSCALE)
        if maps is None:
            maps = lens_maps(image.shape, K, distortion)
        cv2.imwrite(str(target / "image_0" / frame.name), cv2.remap(image, *maps, cv2.INTER_LINEAR,
                                                                   borderMode=cv2.BORDER_CONSTANT))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("clips", type=Path, nargs="?",
                        default=DEFAULT_CLIPS_ROOT)
    parser.add_argument("--model", default="plumb_bob")
    parser.add_argument("--dist", nargs="+", type=float, default=[-0.25, 0.05, 0.0, 0.0])
    args = parser.parse_args()
    distortion = LensDistortion(args.model, tuple(args.dist))
    flags = ["--dist", *map(str, args.dist), "--distortion-model", args.model]
    print(f"| clip | original frames | through the lens ({args.model} {' '.join(map(str, args.dist))}), run "
          "without --dist | through the lens, run with --dist |")
    print("| --- | --- | --- | --- |")
    for clip in CLIPS:
        warp_clip(args.clips, clip, args.out / "data", distortion)
        cells = [run_cell(args.clips, clip, args.out / "original" / clip),
                 run_cell(args.out / "data", clip, args.out / "ignored" / clip),
                 run_cell(args.out / "data", clip, args.out / "undistorted" / clip, flags)]
        print(f"| {clip} | " + " | ".join(cells) + " |")
    print("cells: t_err % / r_err deg/m / path length against the truth (01: 100 m sub-paths, 06/07: 10-50 m)")


if __name__ == "__main__":
    main()
