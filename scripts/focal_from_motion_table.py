"""Print the table of docs/uncalibrated.md: videos without intrinsics, the focal length (and lens) flowvo
estimates from their motion against the truth, the uncertainty it states, and whether that covers the truth;
for drives with ground truth, t_err of the default method with the estimate and calibrated.

Drives (``--drives``, default all): the real KITTI clips 01, 03, 06, 07 as lossless FFV1 videos (truth: P0 of
their calib.txt); the real dash-cam ``dashcam`` (truth: fx 1156.5 of its chessboard photos, its README); two
synthetic strong-lens cameras rendered by ``flowvo synth`` (300 frames at 620x188, top speed 12 m/s):
``barrel`` (seed 3, KITTI's field of view, --dist -0.25 0.05 0 0) and ``wide`` (seed 5, --fov 90,
--dist -0.3 0.08 0 0). Covered: the truth within the stated 2 sigma (the printed range).

Usage: python scripts/focal_from_motion_table.py OUT_DIR [--drives 01 07 ...] [--no-odometry]
Writes the videos to OUT_DIR/videos, the renders to OUT_DIR/synth and the runs to OUT_DIR/NAME/ (never commit
them). A drive takes 1-5 minutes on two shared cores: run a few at a time.
"""

import argparse
import json
import math
import re
import subprocess
import sys
import time
from pathlib import Path

import cv2

from flowvo.camera import LensDistortion
from flowvo.kitti.calib import read_calibration
from flowvo.report.evaluation import evaluate_files
from flowvo.synth.dataset import synthesize
from flowvo.synth.synth_camera import SynthCamera

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real"
KITTI_LENGTHS_M = {"01": (100.0,), "03": (100.0, 200.0), "06": (10.0, 20.0, 30.0, 40.0, 50.0),
                   "07": (10.0, 20.0, 30.0, 40.0, 50.0)}
SYNTHETIC = {"barrel": (3, SynthCamera(distortion=LensDistortion("plumb_bob", (-0.25, 0.05, 0.0, 0.0)))),
             "wide": (5, SynthCamera(fov_deg=90.0, distortion=LensDistortion("plumb_bob", (-0.3, 0.08, 0.0, 0.0))))}
SYNTHETIC_LENGTHS_M = (25.0, 50.0, 75.0, 100.0)
DASHCAM_FX = 1156.5  # the dash-cam's chessboard calibration (shared/data/real/dashcam_udacity/README.md)
FRAME_RATE_HZ = 10.0  # KITTI's and flowvo synth's


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


def run(video: Path, out: Path, camera: list[str], lengths: tuple[float, ...]) -> tuple[subprocess.CompletedProcess,
                                                                                         float]:
    """``flowvo run`` on the video (the default method); the process and its wall-clock seconds."""
    start = time.perf_counter()
    process = subprocess.run([sys.executable, "-m", "flowvo.cli", "-q", "run", "--video", str(video), "--out",
                              str(out), "--force", "--lengths", *(f"{m:g}" for m in lengths), *camera],
                             capture_output=True, text=True)
    return process, time.perf_counter() - start


def drive(name: str, out: Path) -> tuple[Path, float, Path | None, Path | None, tuple[float, ...]]:
    """The drive's video, its true focal length (pixels of its frames), its calibration file and ground-truth
    poses (None for the dash-cam) and the sub-paths it is scored on."""
    if name in KITTI_LENGTHS_M:
        clip = SHARED / "kitti_clips" / "sequences" / name
        video = out / "videos" / f"clip{name}.avi"
        if not video.exists():
            write_video(clip / "image_0", video)
        calib = clip / "calib.txt"
        return video, read_calibration(calib).K0[0, 0], calib, SHARED / "kitti_clips" / "poses" / f"{name}.txt", \
            KITTI_LENGTHS_M[name]
    if name == "dashcam":
        return SHARED / "dashcam_udacity" / "drive_a.mp4", DASHCAM_FX, None, None, (100.0,)
    seed, camera = SYNTHETIC[name]
    root = out / "synth" / name
    video = out / "videos" / f"{name}.avi"
    if not video.exists():
        synthesize(root, ["00"], seed=seed, frames=300, scale=0.5, max_speed_mps=12.0, camera=camera, force=True,
                   workers=1)
        write_video(root / "sequences" / "00" / "image_0", video)
    calib = root / "sequences" / "00" / "calib.txt"
    return video, read_calibration(calib).K0[0, 0], calib, root / "poses" / "00.txt", SYNTHETIC_LENGTHS_M


def t_err(gt: Path, out: Path, video: Path, lengths: tuple[float, ...]) -> str:
    """t_err % of the run in ``out`` (what ``flowvo eval --gt GT --pred OUT/NAME.txt --lengths ...`` prints)."""
    return f"{evaluate_files(gt, out / f'{video.stem}.txt', lengths_m=lengths).metrics['t_err_percent']:.2f} %"


def row(name: str, out: Path, odometry: bool) -> str:
    video, true_fx, calib, gt, lengths = drive(name, out)
    estimated, estimated_s = run(video, out / name / "estimated", [], lengths)
    calibrated = ""
    if odometry and gt:
        run(video, out / name / "calibrated", ["--calib", str(calib)], lengths)[0].check_returncode()
        calibrated = t_err(gt, out / name / "calibrated", video, lengths)
    if estimated.returncode != 0:
        reason = re.search(r"frames: (.*?)\. (Only turns|calibrate)", estimated.stderr)
        return (f"| {name} | {true_fx:.1f} | refused: {reason.group(1) if reason else estimated.stderr.strip()} "
                f"| | | | | | {calibrated} | {estimated_s:.0f} |")
    estimate = json.loads((out / name / "estimated" / "run.json").read_text())["camera"]["estimate"]
    focal_px, sigma = estimate["focal_px"], estimate["relative_uncertainty"]
    error = math.log(focal_px / true_fx)
    lens = estimate["lens"]
    found = "none" if not lens or lens["distortion_model"] == "none" else \
        f"{lens['lambda']:+.3f} +- {lens['lambda_uncertainty']:.3f}"
    parts = "/".join(f"{100 * estimate['uncertainty_parts'][k]:.1f}" for k in ("bootstrap", "principal_point",
                                                                                "lens_model"))
    return (f"| {name} | {true_fx:.1f} | {focal_px:.1f} +- {100 * sigma:.1f} % ({parts}) | "
            f"{focal_px * math.exp(-2 * sigma):.0f}-{focal_px * math.exp(2 * sigma):.0f} | "
            f"{100 * (focal_px / true_fx - 1):+.1f} % | {'yes' if abs(error) <= 2 * sigma else 'NO'} "
            f"({abs(error) / sigma:.1f} sigma) | {found} | {estimate['pairs_used']} | "
            f"{t_err(gt, out / name / 'estimated', video, lengths) if odometry and gt else ''} | {calibrated} | "
            f"{estimated_s:.0f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--drives", nargs="+", default=[*KITTI_LENGTHS_M, "dashcam", *SYNTHETIC],
                        choices=[*KITTI_LENGTHS_M, "dashcam", *SYNTHETIC])
    parser.add_argument("--no-odometry", action="store_true", help="only the estimate, no t_err")
    args = parser.parse_args()
    (args.out / "videos").mkdir(parents=True, exist_ok=True)
    print("| drive | true fx | estimated fx +- 1 sigma (bootstrap / principal point / lens model, %) | 2 sigma, px | "
          "error | covered | lens found (division coefficient) | pairs | t_err estimated | t_err calibrated | "
          "run s |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name in args.drives:
        print(row(name, args.out, not args.no_odometry), flush=True)


if __name__ == "__main__":
    main()
