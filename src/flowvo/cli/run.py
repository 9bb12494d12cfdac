"""Odometry on one drive: ``flowvo run``."""

from __future__ import annotations

import argparse
import math

from flowvo.cli.arguments import FRAME_COUNT, SUB_PATH_M, force_flag
from flowvo.cli.drive_options import add_drive_options, run_options
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M as DEVKIT_LENGTHS_M

UNSCALED_SHARE = 0.1  # more of a run's moving steps than this without a scale measurement: warn


def command(args: argparse.Namespace) -> int:
    from flowvo.drive.run import run

    options = run_options(args, args.out)
    options.mcap, options.frame_id, options.child_frame_id = args.mcap, args.frame_id, args.child_frame_id
    options.force, options.lengths_m = args.force, tuple(sorted(set(args.lengths)))
    if args.rerun or args.rerun_save:
        from flowvo.api.rerun import RerunLogger

        with RerunLogger(spawn=args.rerun, save=args.rerun_save, force=args.force, dataset=args.data) as view:
            summary = run(options, view)
        if args.rerun_save:
            print(f"rerun: {args.rerun_save}")
    else:
        summary = run(options)
    print(f"{summary['label']} on {summary['sequence']}" + (" (synthetic)" if summary["synthetic"] else ""))
    if "estimate" in summary["camera"]:
        print(_estimate_line(summary["camera"]))
    print(_camera_line(summary))
    planes = summary.get("road_planes", {})
    if note := _mounting_note(planes, summary["camera"]["camera_pitch_deg"], summary["camera"]["camera_roll_deg"]):
        print(note)
    if warning := _bowl_warning(planes):
        print(warning)
    for note in _view_notes(summary):
        print(note)
    print(f"poses: {args.out}/{summary['poses']}  timing: {args.out}/timing.json  "
          f"({summary['frames']} frames, {summary['frames_per_second']:.0f} frames/s)")
    print(drive_line(summary["drive"]))
    if summary.get("steps"):
        kinds = summary["scale_window"]["steps_measured_by"]
        print(f"steps: {args.out}/{summary['steps']}  (measured by " + ", ".join(
            f"{kind} {count}" for kind, count in sorted(kinds.items(), key=lambda item: -item[1])) + ")")
        if warning := _unscaled_warning(summary, args.out):
            print(warning)
    if limit := summary.get("speed_limit", {}).get("refused_measurements"):
        from flowvo.methods.flowvo import LOW_CAMERA_HEIGHT_M, MAX_SPEED_MPS  # loaded by the run already

        max_speed_mps = summary["speed_limit"]["max_speed_mps"]
        print(f"note: {limit} measured speeds were refused as faster than {max_speed_mps:.1f} m/s "
              f"({MAX_SPEED_MPS:g} for a camera {LOW_CAMERA_HEIGHT_M:g} m high, in proportion to the height; less soon "
              "after a standstill)")
    if "mcap" in summary:
        print(f"mcap: {args.out}/{summary['mcap']}")
    if "metrics" in summary:
        m = summary["metrics"]
        if m["t_err_percent"] is not None:
            lengths = "" if args.lengths == list(DEVKIT_LENGTHS_M) else \
                f" (sub-paths {', '.join(f'{L:g}' for L in sorted(set(args.lengths)))} m, not the devkit's)"
            print(f"t_err {m['t_err_percent']:.2f} %  r_err {m['r_err_deg_per_m']:.4f} deg/m{lengths}", end="  ")
        print(f"ATE {m['ate_rmse_m']:.2f} m")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="odometry on one drive (KITTI sequence, video, ROS bag): poses, timing, evaluation")
    add_drive_options(p)
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--scale-from", choices=("height", "gt"), default="height",
                   help="classical method's metric scale: the camera height, or GT step lengths (labelled)")
    p.add_argument("--max-frames", type=FRAME_COUNT, help="stop after this many frames")
    p.add_argument("--lengths", nargs="+", type=SUB_PATH_M, default=list(DEVKIT_LENGTHS_M), metavar="M",
                   help="evaluation sub-path lengths in metres (default the devkit's 100..800)")
    p.add_argument("--mcap", action="store_true", help="also write NAME.mcap (nav_msgs/Odometry, /tf, nav_msgs/Path); "
                                                        "always on for --bag")
    p.add_argument("--frame-id", default="odom", help="MCAP parent frame id")
    p.add_argument("--child-frame-id", default="camera_optical", help="MCAP child frame id")
    p.add_argument("--rerun", action="store_true", help="watch it live in the Rerun viewer (spawned): the frame, "
                   "tracked points, road, the path in 3-D, speed and what measured each step (the rerun extra)")
    p.add_argument("--rerun-save", metavar="FILE.rrd", help="record the same view to an .rrd file (rerun FILE.rrd)")
    force_flag(p, "this drive's earlier result in --out (poses, timing, run.json, eval_NAME/, NAME.mcap)")
    p.set_defaults(func=command)


def drive_line(drive: dict) -> str:
    """A drive summary (:func:`flowvo.report.drive_summary.drive_summary`) in one line."""
    return (f"drive: {drive['distance_m']:.1f} m in {drive['duration_s']:.1f} s, mean speed "
            f"{drive['mean_speed_mps']:.1f} m/s ({3.6 * drive['mean_speed_mps']:.0f} km/h), top "
            f"{drive['top_speed_mps']:.1f} m/s ({3.6 * drive['top_speed_mps']:.0f} km/h, over 1 s), heading change "
            f"{drive['heading_change_deg']:+.1f} deg (left +)")


def _bowl_warning(planes: dict) -> str | None:
    """A warning where the road straight ahead lies far off the plane through the nearer road (``run.json``'s
    ``road_planes.far_road_off_plane_share``, :func:`flowvo.odometry.road_profile.RoadProfile.far_road_share`)."""
    from flowvo.odometry.road_profile import FAR_ROAD_H, FAR_ROAD_WARNING_SHARE

    far = planes.get("far_road_off_plane_share")
    if far is None or abs(far) <= FAR_ROAD_WARNING_SHARE:
        return None
    side = "below" if far > 0 else "above"
    return (f"warning: the road {FAR_ROAD_H[0]:g}-{FAR_ROAD_H[1]:g} camera heights ahead lies {100 * abs(far):.0f} % "
            f"of the height {side} the plane through the nearer road (real KITTI: within 4 %): "
            "the road is not a plane to the method, and its lengths are not to be trusted (a road flow too noisy for "
            "its baseline? a wrong camera pitch, lens model or rolling shutter? docs/dashcam.md)")


def _view_notes(summary: dict) -> list[str]:
    """Notes on what the run kept out of the road's view (``run.json``'s ``still_regions`` and ``static_layer``): where
    the frames' view ends above a bonnet, and a still layer over the road taken out of its frames."""
    notes = []
    if (row := summary.get("still_regions", {}).get("view_ends_at_row")) is not None:
        notes.append(f"note: the frames' view ends at row {row} (a bonnet or dashboard that stands still across the "
                     "bottom rows: kept out of the road and the tracks)")
    layer = summary.get("static_layer", {})
    if layer.get("removed_from_moving_frame") is not None:
        notes.append(f"note: a still layer over the road (a reflection or dirt on the windshield: {layer['share']:.2f} "
                     "of the road's texture) was taken out of the road's frames from moving frame "
                     f"{layer['removed_from_moving_frame']} on (docs/dashcam.md#a-reflection-over-the-road)")
    return notes


def _mounting_words(pitch_deg: float, roll_deg: float, places: int | None = None) -> list[str]:
    """A mounting's nonzero pitch and roll (degrees, down and right side down positive) in words: "pitched 1.8 deg
    up", "rolled 4 deg (left side down)" (``places`` decimals; None: as short as it goes)."""
    def size(deg: float) -> str:
        return f"{abs(deg):g}" if places is None else f"{abs(deg):.{places}f}"
    return ([f"pitched {size(pitch_deg)} deg {'down' if pitch_deg > 0 else 'up'}"] if pitch_deg else []) + \
        ([f"rolled {size(roll_deg)} deg ({'right' if roll_deg > 0 else 'left'} side down)"] if roll_deg else [])


def _mounting_note(planes: dict, given_pitch_deg: float, given_roll_deg: float) -> str | None:
    """The note on a mounting taken from the drive (``run.json``'s ``road_planes``), or None when none was: the
    pitch and roll taken and, where they differ from the ones given, the options that give them from the first
    frame."""
    if not planes.get("pitches_taken_deg"):
        return None
    pitch_deg, roll_deg = planes["pitches_taken_deg"][-1], planes["rolls_taken_deg"][-1]
    pitch_changed, roll_changed = bool(round(pitch_deg - given_pitch_deg, 1)), bool(round(roll_deg - given_roll_deg, 1))
    taken = _mounting_words(pitch_deg if pitch_changed else 0.0, roll_deg if roll_changed else 0.0, 1)
    options = ([f"--camera-pitch {pitch_deg:.1f}"] if pitch_changed else []) + \
        ([f"--camera-roll {roll_deg:.1f}"] if roll_changed else [])
    advice = f": {' '.join(options)} measures with it from the first frame" if options else ""
    return (f"note: the camera's mounting was taken from the drive: {', '.join(taken) or 'as given'} (its road planes "
            f"leaned alike; {planes['refused_as_tilted']} refused as tilted){advice} (docs/camera.md)")


def _camera_line(summary: dict) -> str:
    """The run summary's camera in one line."""
    camera = summary["camera"]
    distortion = "no distortion" if camera["distortion_model"] == "none" else \
        f"{camera['distortion_model']} {' '.join(f'{v:g}' for v in camera['distortion'])}"
    height = f"{camera['camera_height_m']:g} m"
    if not camera["camera_height_given"]:
        height += " (KITTI's)" if camera["source"] == "kitti" else \
            " (KITTI's, assumed: give --camera-height M, the camera's height above the road)"
    pitch = "".join(f", {words}" for words in _mounting_words(camera["camera_pitch_deg"], camera["camera_roll_deg"]))
    pitch += f", rolling shutter read out over {camera['readout_ms']:g} ms" if camera.get("readout_ms") else ""
    scaled = "" if "scaled_from_image_size" not in camera else \
        " (scaled to the frames from the calibration's {}x{} images)".format(*camera["scaled_from_image_size"])
    return (f"camera ({camera['source']}): fx {camera['fx']:.1f} fy {camera['fy']:.1f} cx {camera['cx']:.1f} "
            f"cy {camera['cy']:.1f}{scaled}, {distortion}, height {height}{pitch}")


def _estimate_line(camera: dict) -> str:
    """The focal length (and lens) estimated from the motion, and the flags that give them next time, in one
    line; pixels of the frames as decoded."""
    estimate = camera["estimate"]
    focal_px, sigma = estimate["focal_px"], estimate["relative_uncertainty"]
    width, height = estimate["image_size"]
    lens, flags = estimate.get("lens"), ""
    if not estimate.get("lens_estimated", False):
        found = "through the lens given"
    elif lens is None or lens["distortion_model"] == "none":
        found = "no lens distortion found"
    else:
        found = f"lens distortion found (division model {lens['lambda']:+.3f} +- {lens['lambda_uncertainty']:.3f})"
        model = "" if lens["distortion_model"] == "plumb_bob" else f" --distortion-model {lens['distortion_model']}"
        flags = f"{model} --dist {' '.join(f'{k:.6g}' for k in lens['distortion'])}"
    low_px, high_px = focal_px * math.exp(-2 * sigma), focal_px * math.exp(2 * sigma)  # sigma: of log f
    return (f"estimated focal length {focal_px:.0f} px (+- {100 * sigma:.1f} % at 1 sigma: {low_px:.0f}-"
            f"{high_px:.0f} px at 2 sigma), {found}, from {estimate['pairs_used']} frame pairs in "
            f"the first {estimate['frames']} frames, in pixels of the {width}x{height} frames as decoded; next time "
            f"pass --fx {camera['fx']:.1f} --fy {camera['fy']:.1f} --cx {camera['cx']:.1f} --cy {camera['cy']:.1f}"
            + flags)


def _unscaled_warning(summary: dict, out: str) -> str | None:
    """A warning when more than a tenth of the moving steps rest on no measurement of the scale (the held
    speed, or nothing: ``flowvo-geometry`` without a road in sight), else None."""
    window = summary.get("scale_window") or {}
    kinds = window.get("steps_measured_by", {})
    unscaled, moving = window.get("unscaled_steps", 0), sum(kinds.values()) - kinds.get("standstill", 0)
    if not unscaled or unscaled <= UNSCALED_SHARE * moving:
        return None
    return (f"warning: {unscaled} of {moving} moving steps had no road, ratio to a measured step or network distance: "
            f"their lengths are the held speed or zero, not measured ({out}/{summary['steps']}; flowvo, with its "
            "network, measures where no road is seen)")
