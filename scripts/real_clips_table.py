"""Print the README's real-data table: every method on the real KITTI clips (validation data, never
trained on). Clip 01 is scored with the KITTI metric (only its 100 m sub-paths fit in 140 m), clips 06
and 07 devkit-style on 10..50 m sub-paths; plus each path's length against the truth.

Usage: python scripts/real_clips_table.py OUT_DIR [CLIPS_ROOT]   (runs flowvo into OUT_DIR/METHOD/NN)
"""

import json
import sys
from pathlib import Path

from clip_runs import CLIPS, DEFAULT_CLIPS_ROOT, run_cell

METHODS = {"flowvo": [], "flowvo-geometry": [], "flowvo-pair": [], "flowvo-ba": [], "cnn": [], "classical": [],
           "classical_gt": ["--method", "classical", "--scale-from", "gt"]}


def main(out: Path, clips: Path) -> None:
    print("| method | 03 (KITTI metric, 100 and 200 m) | clip 01 (KITTI metric, 100 m) | clip 06 (10-50 m) | clip 07 "
          "(10-50 m) | frames/s (clip 07) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for method, extra in METHODS.items():
        cells = [run_cell(clips, clip, out / method / clip, extra or ["--method", method]) for clip in CLIPS]
        fps = json.loads((out / method / "07" / "timing.json").read_text())["frames_per_second"]
        label = json.loads((out / method / "07" / "run.json").read_text())["label"]
        print(f"| {label} | " + " | ".join(cells) + f" | {fps:.0f} |")
    print("cells: t_err % / r_err deg/m / path length against the truth")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]) if len(sys.argv) > 2 else DEFAULT_CLIPS_ROOT)
