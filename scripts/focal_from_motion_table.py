"""Print the table of docs/uncalibrated.md: the real KITTI clips as videos without intrinsics. For each clip:
the focal length flowvo estimates from the motion against P0's, and t_err of the default method with the
estimate, with the true focal length and the principal point at the centre (what the estimate assumes),
and calibrated (``--calib``). Clip 01 is scored on 100 m sub-paths, 06 and 07 on 10..50 m.

Usage: python scripts/focal_from_motion_table.py OUT_DIR [CLIPS_ROOT]
Writes lossless FFV1 videos of the clips to OUT_DIR/videos (never commit them) and the runs to OUT_DIR/NN/.
"""

import json
import re
import subprocess
import sys
import time
from pathlib import Path

import cv2

from flowvo.kitti.calib import read_calibration
from flowvo.report.evaluation import evaluate_files

CLIPS = {"01": (100.0,), "06": (10.0, 20.0, 30.0, 40.0, 50.0), "07": (10.0, 20.0, 30.0, 40.0, 50.0)}
FRAME_RATE_HZ = 10.0  # KITTI's


def write_video(images: Path, video: Path) -> tuple[int, int]:
    """The PNGs of ``images`` as a lossless grey FFV1 video; its frame size (H, W) (FFV1 needs even sides:
    an odd width loses its last column, which leaves the principal point where it was)."""
    files = sorted(images.glob("*.png"))
    first = cv2.imread(str(files[0]), cv2.IMREAD_GRAYSCALE)
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"FFV1"), FRAME_RATE_HZ, first.shape[::-1], False)
    for file in files:
        writer.write(cv2.imread(str(file), cv2.IMREAD_GRAYSCALE))
    writer.release()
    capture = cv2.VideoCapture(str(video))
    size_hw = (int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT)), int(capture.get(cv2.CAP_PROP_FRAME_WIDTH)))
    capture.release()
    return size_hw


def run(video: Path, out: Path, camera: list[str]) -> tuple[subprocess.CompletedProcess, float]:
    """``flowvo run`` on the video (the default method); the process and its wall-clock seconds."""
    start = time.perf_counter()
    process = subprocess.run([sys.executable, "-m", "flowvo.cli", "-q", "run", "--video", str(video), "--out",
                              str(out), "--force", *camera], capture_output=True, text=True)
    return process, time.perf_counter() - start


def t_err(gt: Path, out: Path, video: Path, lengths: tuple[float, ...]) -> float:
    """t_err % of the run in ``out`` (what ``flowvo eval --gt GT --pred OUT/NAME.txt --lengths ...`` prints)."""
    return evaluate_files(gt, out / f"{video.stem}.txt", lengths_m=lengths).metrics["t_err_percent"]


def main(out: Path, clips: Path) -> None:
    (out / "videos").mkdir(parents=True, exist_ok=True)
    print("| clip | P0 fx | estimated fx | error | pairs | t_err estimated | t_err true fx, centre pp | "
          "t_err calibrated | estimated / calibrated | run s (estimated / calibrated) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for clip, lengths in CLIPS.items():
        video = out / "videos" / f"clip{clip}.avi"
        h, w = write_video(clips / "sequences" / clip / "image_0", video)
        calib = clips / "sequences" / clip / "calib.txt"
        gt = clips / "poses" / f"{clip}.txt"
        true_fx = read_calibration(calib).K0[0, 0]
        calibrated, calibrated_s = run(video, out / clip / "calibrated", ["--calib", str(calib)])
        calibrated.check_returncode()
        calibrated_err = t_err(gt, out / clip / "calibrated", video, lengths)
        estimated, estimated_s = run(video, out / clip / "estimated", [])
        if estimated.returncode != 0:
            reason = re.search(r"frames: (.*?)\. Only turns", estimated.stderr).group(1)
            print(f"| {clip} | {true_fx:.1f} | not observable ({reason}) | | | | | {calibrated_err:.2f} % | | "
                  f"{estimated_s:.0f} / {calibrated_s:.0f} |")
            continue
        estimate = json.loads((out / clip / "estimated" / "run.json").read_text())["camera"]["estimate"]
        centre = ["--fx", str(true_fx), "--fy", str(true_fx), "--cx", str((w - 1) / 2), "--cy", str((h - 1) / 2)]
        run(video, out / clip / "true_fx_centre", centre)[0].check_returncode()
        estimated_err = t_err(gt, out / clip / "estimated", video, lengths)
        focal_px, uncertainty = estimate["focal_px"], estimate["relative_uncertainty"]
        print(f"| {clip} | {true_fx:.1f} | {focal_px:.1f} +- {100 * uncertainty:.1f} % "
              f"| {100 * (focal_px / true_fx - 1):+.1f} % | {estimate['pairs_used']} | {estimated_err:.2f} % | "
              f"{t_err(gt, out / clip / 'true_fx_centre', video, lengths):.2f} % | {calibrated_err:.2f} % | "
              f"{estimated_err / calibrated_err:.2f}x | {estimated_s:.0f} / {calibrated_s:.0f} |")
    print("t_err: clip 01 on 100 m sub-paths, 06 and 07 on 10..50 m; run s: wall clock of the whole flowvo run")


if __name__ == "__main__":
    default = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real" / "kitti_clips"
    main(Path(sys.argv[1]), Path(sys.argv[2]) if len(sys.argv) > 2 else default)
