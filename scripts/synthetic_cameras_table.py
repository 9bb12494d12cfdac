"""Print the synthetic-cameras table: the default method on one synthetic world and drive seen by KITTI's
camera and by other cameras (each change alone, then all together), t_err and the estimated path length
against the truth. The last rows: a camera pitched down, told so by its calib.txt, and run as if level.

Usage: python scripts/synthetic_cameras_table.py OUT_DIR [--frames 300] [--seed 3] [--scale 0.5]
       [--max-speed 12] [--lengths 25 50 75 100]
(renders into OUT_DIR/camera_N/data and runs flowvo into OUT_DIR/camera_N/run)
"""

import argparse
from pathlib import Path

from flowvo.camera import LensDistortion
from flowvo.drive.options import RunOptions
from flowvo.drive.run import run
from flowvo.kitti.poses import read_kitti_poses
from flowvo.metrics.kitti_odometry import trajectory_distances
from flowvo.synth.dataset import synthesize
from flowvo.synth.synth_camera import SynthCamera

BARREL = LensDistortion("plumb_bob", (-0.25, 0.05, 0.0, 0.0))
CAMERAS = {
    "KITTI (1.65 m, 81.6 deg, pinhole, 10 fps)": SynthCamera(),
    "height 1.2 m": SynthCamera(height_m=1.2),
    "fov 90 deg": SynthCamera(fov_deg=90.0),
    "barrel k1 -0.25 k2 0.05": SynthCamera(distortion=BARREL),
    "30 fps": SynthCamera(fps=30.0),
    "all four": SynthCamera(height_m=1.2, fov_deg=90.0, distortion=BARREL, fps=30.0),
    "pitched 8 deg down": SynthCamera(pitch_deg=8.0),
    "pitched 8 deg down, run as if level (--camera-pitch 0)": SynthCamera(pitch_deg=8.0),
}
TOLD_PITCH_DEG = {"pitched 8 deg down, run as if level (--camera-pitch 0)": 0.0}  # run options that override the
# camera's calib.txt


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--frames", type=int, default=300, help="frames of the drive at 10 Hz")
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--scale", type=float, default=0.5)
    parser.add_argument("--max-speed", type=float, default=12.0, help="top speed of the generated drive, m/s")
    parser.add_argument("--lengths", type=float, nargs="+", default=[25.0, 50.0, 75.0, 100.0])
    args = parser.parse_args()
    print(f"seed {args.seed}, {args.frames / 10:g} s drive, scale {args.scale:g}, sub-paths "
          f"{' '.join(f'{m:g}' for m in args.lengths)} m")
    print("| camera | frames | t_err % | r_err deg/m | path length vs truth | t_err / KITTI camera's |")
    print("| --- | --- | --- | --- | --- | --- |")
    reference = None
    for index, (label, camera) in enumerate(CAMERAS.items()):
        root = args.out / f"camera_{index}" / "data"
        frames = (args.frames - 1) * round(camera.fps / 10) + 1  # the same drive (fps is a multiple of 10 here)
        synthesize(root, ["00"], seed=args.seed, frames=frames, scale=args.scale, max_speed_mps=args.max_speed,
                   camera=camera, force=True)
        summary = run(RunOptions(out=str(root.parent / "run"), data=str(root), sequence="00",
                                 lengths_m=tuple(args.lengths), force=True, camera_pitch_deg=TOLD_PITCH_DEG.get(label)))
        metrics = summary["metrics"]
        truth = trajectory_distances(read_kitti_poses(root / "poses" / "00.txt").positions)[-1]
        length = trajectory_distances(read_kitti_poses(root.parent / "run" / "00.txt").positions)[-1]
        reference = reference or metrics["t_err_percent"]
        print(f"| {label} | {summary['frames']} | {metrics['t_err_percent']:.2f} | {metrics['r_err_deg_per_m']:.4f} "
              f"| {100 * (length / truth - 1):+.1f} % of {truth:.0f} m | {metrics['t_err_percent'] / reference:.2f}x |")


if __name__ == "__main__":
    main()
