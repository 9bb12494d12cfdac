"""Print the synthetic-cameras table: the default method on one synthetic world and drive seen by KITTI's
camera and by other cameras (each change alone, then all together), t_err and the estimated path length
against the truth, and the road planes trusted and refused as tilted. Then cameras pitched down or up, told so by
their calib.txt, and run as if level; a bonnet; a strong barrel lens; and a dash-cam (bonnet, pitched 3 degrees
down, that lens, 1.3 m high, 25 frames/s), told its pitch, then not told (run as if level); cameras rolled, not
told their roll (run as if level), and one told.

Usage: python scripts/synthetic_cameras_table.py OUT_DIR [--frames 300] [--seed 3] [--scale 0.5]
       [--max-speed 12] [--lengths 25 50 75 100] [--rows 0 8 9]
(renders into OUT_DIR/camera_N/data and runs flowvo into OUT_DIR/camera_N/run; rows sharing a camera share its
render; row 0, KITTI's camera, is always run: the last column's reference)
"""

import argparse
from pathlib import Path

from flowvo.camera import KITTI_CAMERA_HEIGHT_M, LensDistortion
from flowvo.drive.options import RunOptions
from flowvo.drive.run import run
from flowvo.kitti.poses import read_kitti_poses
from flowvo.metrics.kitti_odometry import trajectory_distances
from flowvo.synth.dataset import synthesize
from flowvo.synth.frame_rate import frames_spanning
from flowvo.synth.synth_camera import PATH_RATE_HZ, SynthCamera

BARREL = LensDistortion("plumb_bob", (-0.25, 0.05, 0.0, 0.0))
STRONG_BARREL = LensDistortion("plumb_bob", (-0.35, 0.1, 0.0, 0.0))
BONNET_ROWS = 0.08  # the real dash-cam's bonnet covers its rows from about 664 of 720 (its README)
DASH_CAM = SynthCamera(height_m=1.3, distortion=STRONG_BARREL, fps=25.0, pitch_deg=3.0, bonnet_rows=BONNET_ROWS)
NOT_TOLD = "the dash-cam, pitch not told (run as if level)"
CAMERAS = {
    "KITTI (1.65 m, 81.6 deg, pinhole, 10 fps)": SynthCamera(),
    "height 1.2 m": SynthCamera(height_m=1.2),
    "fov 90 deg": SynthCamera(fov_deg=90.0),
    "barrel k1 -0.25 k2 0.05": SynthCamera(distortion=BARREL),
    "30 fps": SynthCamera(fps=30.0),
    "all four": SynthCamera(height_m=1.2, fov_deg=90.0, distortion=BARREL, fps=30.0),
    "pitched 8 deg down": SynthCamera(pitch_deg=8.0),
    "pitched 8 deg down, run as if level (--camera-pitch 0)": SynthCamera(pitch_deg=8.0),
    f"bonnet {BONNET_ROWS:g} of the height": SynthCamera(bonnet_rows=BONNET_ROWS),
    "pitched 3 deg down (told)": SynthCamera(pitch_deg=3.0),
    "pitched 5 deg up (told)": SynthCamera(pitch_deg=-5.0),
    "barrel k1 -0.35 k2 0.1 (told)": SynthCamera(distortion=STRONG_BARREL),
    "the dash-cam: bonnet, 3 deg down, k1 -0.35 k2 0.1, 1.3 m, 25 fps (told all)": DASH_CAM,
    NOT_TOLD: DASH_CAM,
    "rolled 6 deg, right side down, run as if level": SynthCamera(roll_deg=6.0),
    "pitched 5 deg down, rolled 4 deg left side down, run as if level": SynthCamera(pitch_deg=5.0, roll_deg=-4.0),
    "pitched 5 deg up, run as if level": SynthCamera(pitch_deg=-5.0),
    "rolled 6 deg, right side down (told)": SynthCamera(roll_deg=6.0),
}
RUN_AS_IF_LEVEL = ("pitched 8 deg down, run as if level (--camera-pitch 0)", NOT_TOLD,
                   "rolled 6 deg, right side down, run as if level",
                   "pitched 5 deg down, rolled 4 deg left side down, run as if level",
                   "pitched 5 deg up, run as if level")  # run with --camera-pitch 0 --camera-roll 0, whatever the
# camera's calib.txt says


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--frames", type=int, default=300, help="frames of the drive at 10 Hz")
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--scale", type=float, default=0.5)
    parser.add_argument("--max-speed", type=float, default=12.0, help="top speed of the generated drive, m/s")
    parser.add_argument("--lengths", type=float, nargs="+", default=[25.0, 50.0, 75.0, 100.0])
    parser.add_argument("--rows", type=int, nargs="+", help="only these rows (0-based; row 0 always)")
    parser.add_argument("--ground-texture-scale", type=float, default=1.0,
                        help="the ground's texture this many times finer in every row (flowvo synth's option)")
    parser.add_argument("--matched-ground-texture", action="store_true",
                        help="each row's ground texture finer by KITTI's camera height over its own, so that every "
                             "camera sees the ground's texture in pixels as KITTI's camera does")
    args = parser.parse_args()
    print(f"seed {args.seed}, {(args.frames - 1) / PATH_RATE_HZ:g} s drive, scale {args.scale:g}, sub-paths "
          f"{' '.join(f'{m:g}' for m in args.lengths)} m{_ground_texture_note(args)}")
    print("| camera | frames | t_err % | r_err deg/m | path length vs truth | t_err / KITTI camera's "
          "| road planes trusted / refused as tilted | pitch, roll taken from the drive (deg) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    rows = set(args.rows or range(len(CAMERAS))) | {0}
    reference, rendered = None, {}
    for index, (label, camera) in enumerate(CAMERAS.items()):
        if index not in rows:
            continue
        root = rendered.get(camera, args.out / f"camera_{index}" / "data")
        if camera not in rendered:
            texture_scale = args.ground_texture_scale * (
                KITTI_CAMERA_HEIGHT_M / camera.height_m if args.matched_ground_texture else 1.0)
            synthesize(root, ["00"], seed=args.seed, frames=frames_spanning(args.frames, PATH_RATE_HZ, camera.fps),
                       scale=args.scale, max_speed_mps=args.max_speed, camera=camera, force=True,
                       ground_texture_scale=texture_scale)  # the same drive
            rendered[camera] = root
        out = args.out / f"camera_{index}" / "run"
        level = 0.0 if label in RUN_AS_IF_LEVEL else None
        summary = run(RunOptions(out=str(out), data=str(root), sequence="00", lengths_m=tuple(args.lengths),
                                 force=True, camera_pitch_deg=level, camera_roll_deg=level))
        reference = reference or summary["metrics"]["t_err_percent"]
        print(_row(label, summary, root, out, reference))


def _ground_texture_note(args: argparse.Namespace) -> str:
    """How the ground's texture was rendered, where not by default."""
    notes = ([] if args.ground_texture_scale == 1.0 else [f"{args.ground_texture_scale:g} times finer"]) + \
        (["finer by KITTI's camera height over each camera's"] if args.matched_ground_texture else [])
    return f", the ground's texture {' and '.join(notes)}" if notes else ""


def _row(label: str, summary: dict, root: Path, out: Path, reference: float) -> str:
    """One table row: the run's scores against the truth, its road planes and the mountings it took from the drive."""
    metrics, planes = summary["metrics"], summary["road_planes"]
    truth = trajectory_distances(read_kitti_poses(root / "poses" / "00.txt").positions)[-1]
    length = trajectory_distances(read_kitti_poses(out / "00.txt").positions)[-1]
    taken = "; ".join(f"{pitch_deg:.1f}, {roll_deg:.1f}" for pitch_deg, roll_deg in
                      zip(planes["pitches_taken_deg"], planes["rolls_taken_deg"], strict=True)) or "none"
    return (f"| {label} | {summary['frames']} | {metrics['t_err_percent']:.2f} | {metrics['r_err_deg_per_m']:.4f} "
            f"| {100 * (length / truth - 1):+.1f} % of {truth:.0f} m | {metrics['t_err_percent'] / reference:.2f}x "
            f"| {planes['trusted']} / {planes['refused_as_tilted']} | {taken} |")


if __name__ == "__main__":
    main()
