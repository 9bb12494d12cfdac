"""Print the README's real-data table: every method on the real KITTI clips (validation data, never
trained on). Clip 01 is scored with the KITTI metric (only its 100 m sub-paths fit in 140 m), clips 06
and 07 devkit-style on 10..50 m sub-paths; plus each path's length against the truth.

Usage: python scripts/real_clips_table.py OUT_DIR [CLIPS_ROOT]   (runs flowvo into OUT_DIR/METHOD/NN)
"""

import json
import subprocess
import sys
from pathlib import Path

from flowvo.kitti.poses import read_kitti_poses
from flowvo.metrics.kitti_odometry import trajectory_distances

METHODS = {"flowvo": [], "flowvo-geometry": [], "cnn": [], "classical": [],
           "classical_gt": ["--method", "classical", "--scale-from", "gt"]}
CLIPS = {"01": ["100"], "06": ["10", "20", "30", "40", "50"], "07": ["10", "20", "30", "40", "50"]}


def main(out: Path, clips: Path) -> None:
    print("| method | clip 01 (KITTI metric, 100 m) | clip 06 (10-50 m) | clip 07 (10-50 m) | frames/s (clip 07) |")
    print("| --- | --- | --- | --- | --- |")
    for method, extra in METHODS.items():
        cells, fps = [], ""
        for clip, lengths in CLIPS.items():
            folder = out / method / clip
            args = extra or ["--method", method]
            subprocess.run(["flowvo", "-q", "run", "--data", str(clips), "--sequence", clip, "--out", str(folder),
                            "--force", "--lengths", *lengths, *args], check=True, capture_output=True)
            metrics = json.loads((folder / f"eval_{clip}" / "metrics.json").read_text())
            truth = trajectory_distances(read_kitti_poses(clips / "poses" / f"{clip}.txt").positions)[-1]
            length = trajectory_distances(read_kitti_poses(folder / f"{clip}.txt").positions)[-1]
            cells.append(f"{metrics['t_err_percent']:.2f} / {metrics['r_err_deg_per_m']:.4f} / "
                         f"{100 * (length / truth - 1):+.1f} %")
            if clip == "07":
                fps = f"{json.loads((folder / 'timing.json').read_text())['frames_per_second']:.0f}"
        label = json.loads((out / method / "07" / "run.json").read_text())["label"]
        print(f"| {label} | " + " | ".join(cells) + f" | {fps} |")
    print("cells: t_err % / r_err deg/m / path length against the truth")


if __name__ == "__main__":
    default = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real" / "kitti_clips"
    main(Path(sys.argv[1]), Path(sys.argv[2]) if len(sys.argv) > 2 else default)
