"""The ``flowvo`` command line: thin sub-commands that parse, call the library and print."""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from flowvo import __version__
from flowvo.errors import FlowvoError
from flowvo.flow.registry import available_methods as available_flow_methods
from flowvo.methods import DEFAULT_METHOD, METHODS, methods_help
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M as DEVKIT_LENGTHS_M
from flowvo.progress import set_progress_enabled
from flowvo.scale_window import LATENCY_FRAMES, MAX_LATENCY_FRAMES

if TYPE_CHECKING:
    from flowvo.drive import RunOptions

def _bounded(kind: type, low: float, high: float = math.inf, low_open: bool = False) -> Callable[[str], float]:
    """An argparse ``type=``: a finite ``kind`` (int or float) in [low, high] ((low, high] if ``low_open``)."""
    def parse(text: str) -> float:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {'an integer' if kind is int else 'a number'}, "
                                             f"got {text!r}") from None
        if not math.isfinite(value) or value < low or (low_open and value == low) or value > high:
            interval = f"{'(' if low_open else '['}{low:g}, {high:g}]"
            raise argparse.ArgumentTypeError(f"{text} is outside {interval}")
        return value

    parse.__name__ = kind.__name__  # argparse names the type in its messages
    return parse


POSITIVE_INT = _bounded(int, 1)
NON_NEGATIVE_INT = _bounded(int, 0)
FRAME_COUNT = _bounded(int, 2)  # a sequence needs two frames for one motion
FLOW_SCALE = _bounded(float, 0.0, 2.0, low_open=True)
IMAGE_SCALE = _bounded(float, 0.0, 4.0, low_open=True)
POSITIVE_FLOAT = _bounded(float, 0.0, 1e6, low_open=True)
UNSCALED_SHARE = 0.1  # more of a run's moving steps than this without a scale measurement: warn
SUB_PATH_M = _bounded(float, 1.0, 1e5)  # shorter sub-paths measure one frame's noise, not drift (1e-30 m: 1e31 %)


class _DefaultsFormatter(argparse.HelpFormatter):
    """``--help`` shows every option's default, unless the help already says it or there is none."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if default in (None, False, argparse.SUPPRESS) or "default" in text or not action.option_strings:
            return text
        shown = " ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in default) \
            if isinstance(default, list | tuple) else default
        return f"{text} (default: {shown})".replace("%", "%%") if "%" not in text else text


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line on stderr (exit 2), like every other flowvo error."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _force_flag(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--force", action="store_true", help=f"replace {what} (otherwise an existing one is refused)")


def _cmd_eval(args: argparse.Namespace) -> int:
    from flowvo.evaluation import EVALUATION_FILES, evaluate_files, format_table, save_evaluation
    from flowvo.outputs import prepare_output_dir

    evaluation = evaluate_files(args.gt, args.pred, args.align, tuple(sorted(set(args.lengths))))
    print(format_table(evaluation.metrics))
    if args.out:
        prepare_output_dir(args.out, EVALUATION_FILES, args.force)
        written = save_evaluation(evaluation, args.out)
        print(f"\nwrote {len(written)} files to {args.out} (metrics.json, plots)")
    return 0


def _add_eval(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("eval", help="score a KITTI pose file against ground truth (KITTI metric, ATE, RPE)")
    p.add_argument("--gt", required=True, help="ground-truth KITTI pose file")
    p.add_argument("--pred", required=True, help="predicted KITTI pose file (12 floats, or frame index + 12)")
    p.add_argument("--align", choices=("none", "6dof", "7dof"), default="none", help="alignment for ATE only")
    p.add_argument("--out", help="folder for metrics.json, per_frame_errors.csv and PNG plots")
    p.add_argument("--lengths", nargs="+", type=SUB_PATH_M, default=list(DEVKIT_LENGTHS_M), metavar="M",
                   help="sub-path lengths in metres (default the devkit's 100 200 ... 800; e.g. 10 20 30 40 50 "
                        "for short drives: the output then says the lengths differ)")
    _force_flag(p, "an earlier evaluation in --out")
    p.set_defaults(func=_cmd_eval)


def _cmd_synth(args: argparse.Namespace) -> int:
    from flowvo.camera import LensDistortion
    from flowvo.synth.dataset import synthesize
    from flowvo.synth.synth_camera import SynthCamera

    camera = SynthCamera(args.camera_height, args.fov, LensDistortion(args.distortion_model, tuple(args.distortion)),
                         args.fps, args.camera_pitch)
    folders = synthesize(args.out, args.sequences, args.seed, args.frames, args.trajectory, args.scale,
                         args.scene, args.gt_flow, args.workers, args.max_speed, args.force, camera)
    for folder in folders:
        print(f"wrote {folder} (synthetic)")
    return 0


def _add_synth(sub: argparse._SubParsersAction) -> None:
    from flowvo.camera import KITTI_CAMERA_HEIGHT_M, MAX_CAMERA_PITCH_DEG
    from flowvo.synth.synth_camera import PATH_RATE_HZ
    from flowvo.synth.world import SCENE_TYPES

    p = sub.add_parser("synth", help="render synthetic driving sequences in the KITTI layout (exact GT)")
    p.add_argument("--out", required=True, help="dataset root to write (ROOT/sequences/NN, ROOT/poses)")
    p.add_argument("--sequences", nargs="+", default=["00"], help="sequence names, e.g. 00 01")
    p.add_argument("--frames", type=FRAME_COUNT, help="frames per sequence at --fps (generated default: a 40 s drive; "
                   "truncates replays)")
    p.add_argument("--trajectory", help="replay poses: a KITTI pose file, or a folder holding NN.txt per sequence")
    p.add_argument("--seed", type=NON_NEGATIVE_INT, default=0, help="world and path seed")
    p.add_argument("--scale", type=IMAGE_SCALE, default=1.0, help="image scale: 1.0 = 1241x376, 0.5 = 620x188")
    p.add_argument("--scene", choices=SCENE_TYPES, help="one scene type throughout (default: varied stretches)")
    p.add_argument("--gt-flow", action="store_true", help="also write true forward flow to flow_gt/NNNNNN.npy")
    camera = p.add_argument_group("camera (default KITTI's; calib.txt records what flowvo run needs)")
    camera.add_argument("--camera-height", type=_bounded(float, 0.0, 10.0, low_open=True),
                        default=KITTI_CAMERA_HEIGHT_M, metavar="M",
                        help="camera height above the road in metres (default 1.65)")
    camera.add_argument("--camera-pitch", type=_bounded(float, -MAX_CAMERA_PITCH_DEG, MAX_CAMERA_PITCH_DEG),
                        default=0.0, metavar="DEG", help="camera pitched down by DEG degrees (default 0: level)")
    camera.add_argument("--fov", type=_bounded(float, 20.0, 150.0), metavar="DEG",
                        help="horizontal field of view in degrees (default KITTI's focal length, ~81.6)")
    camera.add_argument("--distortion", "--dist", nargs="+", type=float, default=[], metavar="K",
                        help="lens distortion: k1 k2 p1 p2 [k3] (plumb_bob) or k1 k2 k3 k4 (equidistant)")
    camera.add_argument("--distortion-model", choices=("plumb_bob", "equidistant"), default="plumb_bob",
                        help="lens model of --distortion (default plumb_bob)")
    camera.add_argument("--fps", type=_bounded(float, 1.0, 120.0), default=PATH_RATE_HZ, metavar="HZ",
                        help="frame rate: the same drive sampled at HZ (default 10, KITTI's); times.txt follows")
    p.add_argument("--workers", type=_bounded(int, 1, 64), help="render processes (default: all cores, at most 8)")
    p.add_argument("--max-speed", type=_bounded(float, 0.0, 100.0, low_open=True), default=25.0,
                   help="generated paths: top speed in m/s")
    p.add_argument("--force", action="store_true",
                   help="write into a non-empty --out: sequences rendered differently before are replaced whole, "
                        "other content is kept (without it a non-empty --out is refused, except to resume)")
    p.set_defaults(func=_cmd_synth)


def _cmd_flow(args: argparse.Namespace) -> int:
    from flowvo.flow.cache import FlowCache
    from flowvo.flow.cache_root import default_cache_root
    from flowvo.flow.registry import create_estimator
    from flowvo.flow.visualize import flow_picture_names, save_flow_pictures
    from flowvo.kitti.sequence import KittiSequence
    from flowvo.outputs import prepare_output_dir

    if not args.visualize and (args.gif or args.every != 1):
        raise FlowvoError("--gif and --every apply to the pictures: give --visualize DIR too")
    sequence = KittiSequence(args.data, args.sequence)
    estimator = create_estimator(args.method, args.flow_weights)
    cache = FlowCache(args.cache or default_cache_root(args.data), sequence, args.method, args.scale,
                      estimator.params())
    pairs = range(0, cache.n_pairs, args.every)
    if args.visualize:
        prepare_output_dir(args.visualize, flow_picture_names(pairs, args.gif), args.force, args.data, "--visualize")
    timing = cache.compute(estimator)
    if timing["discarded"]:
        print(f"discarded an earlier flow cache: {timing['discarded']}")
    if timing["replaced"]:
        print(f"recomputed {timing['replaced']} damaged chunk(s) (size, shape or checksum did not match meta.json)")
    if timing["pairs"]:
        print(f"computed {timing['pairs']} pairs: {timing['flow_s'] / timing['pairs']:.4f} s/pair flow, "
              f"{timing['read_s'] / timing['pairs']:.4f} s/pair image read")
    h, w = cache.flow_size_hw
    print(f"flow cache complete: {cache.directory} ({cache.n_pairs} pairs, {w}x{h})")
    if args.visualize:
        magnitude = max(float(np.percentile(np.hypot(*cache.read(p).transpose(2, 0, 1)), 99)) for p in pairs[:20])
        written = save_flow_pictures(((p, cache.read(p)) for p in pairs), args.visualize, magnitude, args.gif)
        print(f"wrote {len(written)} pictures to {args.visualize} (colour wheel, max {magnitude:.1f} px)")
    return 0


def _add_flow(sub: argparse._SubParsersAction) -> None:
    from flowvo.flow.registry import available_methods

    p = sub.add_parser("flow", help="compute (or resume) the flow cache of a sequence; optional colour pictures")
    p.add_argument("--data", required=True, help="dataset root in the KITTI layout")
    p.add_argument("--sequence", required=True, help="sequence name, e.g. 09")
    p.add_argument("--method", default="dis-fast", choices=available_methods(), help="flow method")
    p.add_argument("--scale", type=FLOW_SCALE, default=0.5, help="working resolution relative to the frames")
    p.add_argument("--cache", help="cache root (default: ~/.cache/flowvo/flow/<dataset>-<hash>, "
                                   "$XDG_CACHE_HOME respected)")
    p.add_argument("--flow-weights", help="local weights for flownets / raft-*")
    p.add_argument("--visualize", metavar="DIR", help="write colour-wheel pictures of the flow here")
    p.add_argument("--every", type=POSITIVE_INT, default=1, help="with --visualize: every N-th pair")
    p.add_argument("--gif", action="store_true", help="with --visualize: also an animated flow.gif")
    _force_flag(p, "earlier pictures in --visualize")
    p.set_defaults(func=_cmd_flow)


def _cmd_train(args: argparse.Namespace) -> int:
    from flowvo.model.config import SPLITS, TrainConfig
    from flowvo.model.train import train

    run_config = Path(args.out or TrainConfig().out, "config.yaml")
    if args.config:
        config = TrainConfig.from_yaml(args.config)
    else:  # --resume alone continues with the run's own settings
        config = TrainConfig.from_yaml(run_config) if args.resume and run_config.is_file() else TrainConfig()
    overrides = {"data": args.data, "out": args.out, "epochs": args.epochs, "batch_size": args.batch_size,
                 "learning_rate": args.lr, "seed": args.seed, "flow_method": args.flow_method,
                 "flow_scale": args.flow_scale, "flow_cache": args.cache, "device": args.device}
    for key, value in overrides.items():
        if value is not None:
            setattr(config, key, value)
    if args.split:
        config.train_sequences, config.val_sequences = (list(s) for s in SPLITS[args.split])
    if args.train:
        config.train_sequences = args.train
    if args.val:
        config.val_sequences = args.val
    if args.width:
        config.model.width = args.width
    if args.head:
        config.model.head = args.head
    if args.stack:
        config.model.stack = args.stack
    if not config.data:
        raise FlowvoError("no data: give --data ROOT or 'data:' in the config")
    config.validate()
    from flowvo.model.network import OdometryNet, flops_per_frame, parameter_count

    network = OdometryNet(config.model)
    print(f"model: width {config.model.width}, input {config.model.input_hw[1]}x{config.model.input_hw[0]}, "
          f"head {config.model.head}, stack {config.model.stack}: {parameter_count(network) / 1e6:.2f} M parameters, "
          f"{flops_per_frame(network) / 1e9:.3f} GFLOP per frame")
    out = train(config, resume=args.resume, force=args.force)
    print(f"training finished: {out}/best.pt, log {out}/log.csv, curve {out}/learning_curve.png")
    return 0


def _add_train(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("train", help="train the odometry CNN (checkpoints every epoch, --resume, DDP via torchrun)")
    p.add_argument("--config", help="YAML with TrainConfig fields (flags below override it)")
    p.add_argument("--data", help="dataset root (KITTI layout, real or synthetic)")
    p.add_argument("--out", help="run folder (default runs/train)")
    p.add_argument("--split", choices=("kitti",),
                   help="preset split: kitti = train 00-07, validate 08-10 (the reference split has no "
                        "separate validation set: epoch selection then sees the test sequences)")
    p.add_argument("--train", nargs="+", help="training sequences")
    p.add_argument("--val", nargs="+", help="validation sequences")
    p.add_argument("--epochs", type=POSITIVE_INT)
    p.add_argument("--batch-size", type=POSITIVE_INT)
    p.add_argument("--lr", type=_bounded(float, 0.0, 10.0, low_open=True))
    p.add_argument("--seed", type=NON_NEGATIVE_INT)
    p.add_argument("--width", type=_bounded(float, 0.01, 4.0), help="channel width multiplier (1.0 = thesis network)")
    p.add_argument("--head", choices=("planar", "se3"))
    p.add_argument("--stack", type=_bounded(int, 1, 16), help="consecutive flow fields as input")
    p.add_argument("--flow-method", help="flow method of the caches")
    p.add_argument("--flow-scale", type=FLOW_SCALE, help="flow working scale relative to the frames")
    p.add_argument("--cache", help="flow cache root (default: the user's cache folder, see 'flowvo flow --help')")
    p.add_argument("--device", help="cpu or cuda")
    p.add_argument("--resume", action="store_true",
                   help="continue from OUT/last.pt with the run's settings (changing one that shapes the result "
                        "is refused)")
    _force_flag(p, "an earlier training run in --out (its checkpoints and log are removed first)")
    p.set_defaults(func=_cmd_train)


def _add_drive_options(p: argparse.ArgumentParser, methods_default: str | None = DEFAULT_METHOD,
                       one_drive: bool = True) -> None:
    """The drive, camera and method options of ``run``, ``bench`` and ``batch`` (``one_drive`` False: no
    drive options but the bag topics, which apply to every bag of a batch)."""
    from flowvo.camera import MAX_CAMERA_PITCH_DEG

    drive = p.add_argument_group("drive (one of)" if one_drive else "bags")
    if one_drive:
        drive.add_argument("--data", help="dataset root in the KITTI layout (with --sequence)")
        drive.add_argument("--sequence", help="sequence name under DATA/sequences, e.g. 07")
        drive.add_argument("--video", help="a video file OpenCV reads (with --calib or --fx --fy --cx --cy; without "
                                           "them the focal length is estimated from the motion in its first frames)")
        drive.add_argument("--bag", help="a ROS 1 .bag, a ROS 2 bag folder or an .mcap (with --topic)")
    drive.add_argument("--topic", help="image topic of the bag (sensor_msgs/Image or CompressedImage)")
    drive.add_argument("--camera-info-topic", help="sensor_msgs/CameraInfo topic of the bag (intrinsics, distortion)")
    camera = p.add_argument_group("camera (pixels of the frames; for a KITTI folder these override its calib.txt)")
    camera.add_argument("--calib", help="calibration file: KITTI calib.txt, OpenCV FileStorage YAML/XML, ROS "
                                        "camera_calibration YAML (what 'flowvo calibrate' writes) or Kalibr camchain")
    for name in ("fx", "fy", "cx", "cy"):
        camera.add_argument(f"--{name}", type=float, help=f"intrinsics: {name} in pixels (all four together)")
    camera.add_argument("--dist", nargs="+", type=float, metavar="K", help="lens distortion coefficients: "
                        "K1 K2 P1 P2 [K3] (plumb_bob), 8 (rational_polynomial) or K1..K4 (equidistant)")
    camera.add_argument("--distortion-model", choices=("plumb_bob", "rational_polynomial", "equidistant"),
                        help="model of --dist (default plumb_bob)")
    camera.add_argument("--camera-height", type=_bounded(float, 0.0, 10.0, low_open=True), metavar="M",
                        help="camera height above the road in metres (default: the calibration's, else KITTI's 1.65)")
    camera.add_argument("--camera-pitch", type=_bounded(float, -MAX_CAMERA_PITCH_DEG, MAX_CAMERA_PITCH_DEG),
                        metavar="DEG", help="the camera points DEG degrees below the road's plane (down positive; "
                                            "default: the calibration's, else 0: mounted level)")
    if methods_default is not None:
        p.add_argument("--method", choices=list(METHODS), default=methods_default, help=methods_help())
    p.add_argument("--model", help="network checkpoint for cnn and flowvo's fallback (default: the packaged model)")
    p.add_argument("--latency", type=_bounded(int, 0, MAX_LATENCY_FRAMES), metavar="FRAMES",
                   help=f"flowvo, flowvo-geometry: each pose is final this many frames late (default "
                        f"{LATENCY_FRAMES}; 0: at once, less accurate: docs/results.md)")
    p.add_argument("--flow-method", choices=available_flow_methods(),
                   help="flow method (flowvo: of the road crop, default dis-road; cnn: default the model's)")


def _run_options(args: argparse.Namespace, out: str) -> RunOptions:
    """RunOptions from the parsed drive options (see :func:`_add_drive_options`)."""
    from flowvo.drive import RunOptions

    return RunOptions(out=out, data=getattr(args, "data", None), sequence=getattr(args, "sequence", None),
                      video=getattr(args, "video", None), bag=getattr(args, "bag", None), topic=args.topic,
                      camera_info_topic=args.camera_info_topic, calib=args.calib, fx=args.fx,
                      fy=args.fy, cx=args.cx, cy=args.cy, distortion=tuple(args.dist) if args.dist else None,
                      distortion_model=args.distortion_model, camera_height_m=args.camera_height,
                      camera_pitch_deg=args.camera_pitch, latency_frames=args.latency,
                      method=getattr(args, "method", DEFAULT_METHOD), model=args.model, flow_method=args.flow_method,
                      classical_scale=getattr(args, "scale_from", "height"),
                      max_frames=getattr(args, "max_frames", None))


def _camera_line(summary: dict) -> str:
    """The run summary's camera in one line."""
    camera = summary["camera"]
    distortion = "no distortion" if camera["distortion_model"] == "none" else \
        f"{camera['distortion_model']} {' '.join(f'{v:g}' for v in camera['distortion'])}"
    height = f"{camera['camera_height_m']:g} m"
    if not camera["camera_height_given"]:
        height += " (KITTI's)" if camera["source"] == "kitti" else \
            " (KITTI's, assumed: give --camera-height M, the camera's height above the road)"
    pitch = f", pitched {camera['camera_pitch_deg']:g} deg down" if camera["camera_pitch_deg"] else ""
    return (f"camera ({camera['source']}): fx {camera['fx']:.1f} fy {camera['fy']:.1f} cx {camera['cx']:.1f} "
            f"cy {camera['cy']:.1f}, {distortion}, height {height}{pitch}")


def _estimate_line(camera: dict) -> str:
    """The focal length estimated from the motion, and the flags that give it next time, in one line."""
    estimate = camera["estimate"]
    return (f"estimated focal length {estimate['focal_px']:.0f} px (+- {100 * estimate['relative_uncertainty']:.1f} %) "
            f"from {estimate['pairs_used']} frame pairs in the first {estimate['frames']} frames; next time pass "
            f"--fx {camera['fx']:.1f} --fy {camera['fy']:.1f} --cx {camera['cx']:.1f} --cy {camera['cy']:.1f}")


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


def _cmd_run(args: argparse.Namespace) -> int:
    from flowvo.pipeline import run

    options = _run_options(args, args.out)
    options.mcap, options.frame_id, options.child_frame_id = args.mcap, args.frame_id, args.child_frame_id
    options.force, options.lengths_m = args.force, tuple(sorted(set(args.lengths)))
    summary = run(options)
    print(f"{summary['label']} on {summary['sequence']}" + (" (synthetic)" if summary["synthetic"] else ""))
    if "estimate" in summary["camera"]:
        print(_estimate_line(summary["camera"]))
    print(_camera_line(summary))
    planes = summary.get("road_planes", {})
    if planes.get("tilted_median_pitch_deg") is not None:
        hint, pitch = planes["tilted_median_pitch_deg"], summary["camera"]["camera_pitch_deg"]
        print(f"warning: {planes['refused_as_tilted']} road planes refused as tilted ({planes['trusted']} trusted), "
              f"by {hint:+.1f} deg of pitch (median): a camera mounted pitched needs --camera-pitch "
              f"{pitch + hint:.1f} (docs/camera.md)")
    print(f"poses: {args.out}/{summary['poses']}  timing: {args.out}/timing.json  "
          f"({summary['frames']} frames, {summary['frames_per_second']:.0f} frames/s)")
    if summary.get("steps"):
        kinds = summary["scale_window"]["steps_measured_by"]
        print(f"steps: {args.out}/{summary['steps']}  (measured by " + ", ".join(
            f"{kind} {count}" for kind, count in sorted(kinds.items(), key=lambda item: -item[1])) + ")")
        if warning := _unscaled_warning(summary, args.out):
            print(warning)
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


def _add_run(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="odometry on one drive (KITTI sequence, video, ROS bag): poses, timing, evaluation")
    _add_drive_options(p)
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
    _force_flag(p, "this drive's earlier result in --out (poses, timing, run.json, eval_NAME/, NAME.mcap)")
    p.set_defaults(func=_cmd_run)


def _cmd_batch(args: argparse.Namespace) -> int:
    from flowvo.batch import discover_drives, run_batch

    drives = discover_drives(args.inputs, exclude=args.out)
    defaults = _run_options(args, args.out)
    defaults.mcap, defaults.frame_id, defaults.child_frame_id = args.mcap, args.frame_id, args.child_frame_id
    defaults.lengths_m = tuple(sorted(set(args.lengths)))
    rows = run_batch(drives, args.out, defaults, workers=args.workers, ray=args.ray, retry_failed=args.retry_failed,
                     force=args.force)
    counts = {status: sum(row.status == status for row in rows) for status in ("ok", "failed", "pending")}
    reused = sum(row.reused for row in rows)
    print(f"{len(rows)} drives: {counts['ok']} ok ({reused} from an earlier run), {counts['failed']} failed, "
          f"{counts['pending']} not run")
    for row in rows:
        if row.status == "failed":
            print(f"failed: {row.drive}: {row.error}")
    print(f"summary: {args.out}/summary.csv, {args.out}/summary.json, {args.out}/index.html")
    return 1 if counts["failed"] else 0


def _add_batch(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("batch", help="odometry on many drives (folders, videos, bags, globs, a manifest): one output "
                                     "folder each, fleet summary, resumable, local processes or Ray")
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="a KITTI dataset root or sequence folder, a video file, a bag, a folder searched for these, "
                        "a glob (quote it), or a manifest (.csv or .jsonl: path, kind, sequence, name, calib, fx, fy, "
                        "cx, cy, camera_height_m, method, topic, camera_info_topic)")
    p.add_argument("--out", required=True, help="batch folder: drives/NAME/ (as flowvo run writes), summary.csv, "
                                                "summary.json, index.html")
    p.add_argument("--workers", type=POSITIVE_INT,
                   help="drives at once (default: one worker process per core; with --ray: tasks in flight, "
                        "default twice the cluster's CPUs)")
    p.add_argument("--ray", metavar="ADDRESS",
                   help="run the drives as Ray tasks: 'auto' (a Ray instance on this machine, for this batch) or a "
                        "running cluster's HOST:PORT / ray://HOST:PORT (needs pip install 'flowvo[ray]'; inputs and "
                        "--out on a file system every node sees at the same path)")
    again = p.add_mutually_exclusive_group()
    again.add_argument("--retry-failed", action="store_true",
                       help="run only the drives the last summary marks failed (others are kept or left pending)")
    again.add_argument("--force", action="store_true",
                       help="recompute every drive (otherwise complete results are kept, and results made with "
                            "other settings are refused)")
    _add_drive_options(p, one_drive=False)  # every drive; a manifest line overrides them for its drive
    p.add_argument("--scale-from", choices=("height", "gt"), default="height",
                   help="classical method's metric scale: the camera height, or GT step lengths (labelled)")
    p.add_argument("--max-frames", type=FRAME_COUNT, help="stop each drive after this many frames")
    p.add_argument("--lengths", nargs="+", type=POSITIVE_FLOAT, default=list(DEVKIT_LENGTHS_M), metavar="M",
                   help="evaluation sub-path lengths in metres, where ground truth exists (default 100..800)")
    p.add_argument("--mcap", action="store_true", help="also write NAME.mcap per drive (always for bags)")
    p.add_argument("--frame-id", default="odom", help="MCAP parent frame id")
    p.add_argument("--child-frame-id", default="camera_optical", help="MCAP child frame id")
    p.set_defaults(func=_cmd_batch)


def _cmd_export(args: argparse.Namespace) -> int:
    from flowvo.model.checkpoint import packaged_model_path, read_checkpoint, write_slim_checkpoint
    from flowvo.model.export import export_onnx, export_torchscript
    from flowvo.model.export_format import export_file_format
    from flowvo.outputs import prepare_output_file

    try:
        file_format = export_file_format(args.out, args.format)
    except ValueError as error:
        raise FlowvoError(str(error)) from None
    model = args.model or packaged_model_path()
    read_checkpoint(model)  # a clear error for a missing or foreign file before anything is written
    out = Path(args.out)
    if out.resolve() == Path(model).resolve():
        raise FlowvoError("--out is the --model file itself; write the export elsewhere", out)
    extra = [out.with_name(out.name + ".json")] if file_format != "slim" else []  # the description
    for target in (out, *extra):
        prepare_output_file(target, args.force)
    if file_format == "slim":
        written = [write_slim_checkpoint(model, args.out)]
    elif file_format == "onnx":
        written = export_onnx(model, args.out, not args.no_symmetric, args.opset)
    else:
        written = export_torchscript(model, args.out, not args.no_symmetric)
    for path in written:
        print(f"wrote {path}")
    return 0


def _add_export(sub: argparse._SubParsersAction) -> None:
    from flowvo.model.export_format import FILE_FORMATS, ONNX_OPSET, ONNX_OPSETS

    p = sub.add_parser("export", help="export a checkpoint: ONNX or TorchScript (+ JSON), or a slim float16 checkpoint")
    p.add_argument("--model", help="checkpoint (default: the packaged model)")
    p.add_argument("--out", required=True, help="output file, e.g. model.onnx, model.ts or default.pt")
    p.add_argument("--format", choices=FILE_FORMATS,
                   help="default: onnx for an .onnx --out, else torchscript. onnx / torchscript: flow "
                        "(B, 2K, h, w) in pixels of the network input -> motion (B, D) in m and rad, "
                        "described in OUT.json (onnx needs: pip install 'flowvo[export]'); "
                        "slim: float16 weights + config + normalisation, runnable by flowvo run (not resumable)")
    p.add_argument("--no-symmetric", action="store_true",
                   help="onnx / torchscript: run only the direct pass, not its average with the mirrored one "
                        "(half the network cost; keeps the small constant heading offset the average cancels)")
    p.add_argument("--opset", type=_bounded(int, *ONNX_OPSETS), default=ONNX_OPSET,
                   help=f"onnx: opset version ({ONNX_OPSETS[0]}..{ONNX_OPSETS[1]})")
    _force_flag(p, "an existing --out file")
    p.set_defaults(func=_cmd_export)


def _cmd_report(args: argparse.Namespace) -> int:
    from flowvo.report import write_report

    lengths_m = tuple(sorted(set(args.lengths))) if args.lengths else None
    print(f"report: {write_report(args.runs, args.out, args.force, lengths_m)}")
    return 0


def _add_report(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("report", help="one HTML page comparing run folders: tables, paths, error curves, timing")
    p.add_argument("runs", nargs="+", help="output folders of 'flowvo run'")
    p.add_argument("--out", required=True, help="report folder (index.html + PNGs)")
    p.add_argument("--lengths", nargs="+", type=SUB_PATH_M, metavar="M",
                   help="sub-path lengths in metres to score (default: each run's own --lengths, from run.json)")
    _force_flag(p, "an earlier report in --out")
    p.set_defaults(func=_cmd_report)


def _cmd_demo(args: argparse.Namespace) -> int:
    from flowvo.demo import demo, summary_lines

    report, runs = demo(args.out, args.data, args.sequence, args.model, args.frames, args.force, args.camera_height)
    kind = "synthetic held-out drive" if args.data is None else f"sequence {args.sequence} of {args.data}"
    print(f"flowvo demo on the {kind}:")
    for line in summary_lines(runs):
        print(f"  {line}")
    print(f"report: {report}")
    if args.data is None:
        print("(synthetic data: a held-out world and drive rendered by flowvo synth, not real KITTI)")
    return 0


def _add_demo(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="one command: synthetic drive (or --data), packaged model, baseline, report")
    p.add_argument("--data", help="KITTI root (default: render a synthetic held-out drive)")
    p.add_argument("--sequence", help="sequence of --data")
    p.add_argument("--model", help="checkpoint of the CNN method (default: the packaged model)")
    p.add_argument("--frames", type=FRAME_COUNT, default=900, help="frames of the synthetic drive")
    p.add_argument("--camera-height", type=_bounded(float, 0.0, 10.0, low_open=True), metavar="M",
                   help="camera height above the road in metres (default: the sequence's calib.txt, else 1.65)")
    p.add_argument("--out", default="runs/demo", help="output folder")
    _force_flag(p, "the runs and report of an earlier demo in --out")
    p.set_defaults(func=_cmd_demo)


def _cmd_bench(args: argparse.Namespace) -> int:
    from flowvo.bench import benchmark, format_bench_table, write_bench_json
    from flowvo.outputs import prepare_output_file

    if args.json:  # checked before the benchmark runs: never into the dataset, never over a file unasked
        prepare_output_file(args.json, args.force, "--json", dataset=args.data)
    options = _run_options(args, "")
    rows = benchmark(options, args.methods, args.frames, args.repeat)
    print(format_bench_table(rows))
    if args.json:
        write_bench_json(args.json, rows)
        print(f"wrote {args.json}")
    return 0


def _add_bench(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="streaming frames/s and seconds per stage of each method, median of repeats")
    _add_drive_options(p, methods_default=None)
    p.add_argument("--methods", nargs="+", choices=list(METHODS), default=["flowvo", "cnn", "classical"],
                   help="methods in table order (default method first)")
    p.add_argument("--frames", type=FRAME_COUNT, default=200, help="frames per run (at least 2)")
    p.add_argument("--repeat", type=POSITIVE_INT, default=3, help="runs per method; the table shows medians")
    p.add_argument("--json", metavar="PATH", help="also write the rows as JSON")
    _force_flag(p, "an existing --json file")
    p.set_defaults(func=_cmd_bench)


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from flowvo.atomic import write_text_atomic
    from flowvo.calibration.board import Board
    from flowvo.calibration.calibrate import COEFFICIENT_NAMES, calibrate
    from flowvo.calibration.files import format_ros_calibration
    from flowvo.calibration.images import open_calibration_images, printable
    from flowvo.outputs import prepare_output_file

    board = Board(args.board, args.rows, args.cols, args.square, args.marker, args.dictionary)
    images = open_calibration_images(args.input, args.every)
    out = Path(args.out)
    if not (args.force and out.is_file()):  # with --force an earlier file stays until the new one replaces it
        prepare_output_file(out)
    result = calibrate(images.frames(), board, args.distortion_model, images.count)
    i, d = result.intrinsics, result.distortion
    h, w = result.image_size_hw
    print(f"board: {board.describe()}")
    print(f"found in {result.views_found} of {result.images_seen} images; {result.views_used} distinct views used "
          f"(corners cover {result.coverage:.0%} of the image, board normals span {result.tilt_spread_deg:.0f} deg)")
    print(f"fx {i.fx:.2f}  fy {i.fy:.2f}  cx {i.cx:.2f}  cy {i.cy:.2f}  (pixels of {w}x{h} frames)")
    if d.is_none:
        print("distortion: none")
    else:
        print(f"distortion {d.model}: " + "  ".join(f"{name} {value:.5g}" for name, value
                                                      in zip(COEFFICIENT_NAMES[d.model], d.coefficients, strict=True)))
    worst = int(np.argmax(result.view_rms_px))
    print(f"RMS reprojection error {result.rms_px:.3f} px (worst view {result.view_rms_px[worst]:.3f} px: "
          f"{result.view_labels[worst]})")
    for warning in result.warnings:
        print(f"warning: {warning}")
    write_text_atomic(out, format_ros_calibration(i, d, result.image_size_hw, args.camera_name, args.camera_height,
                                                  result.rms_px))
    print(f"wrote {printable(out)}")
    height = "" if args.camera_height is not None else " --camera-height M"
    print(f"use it: flowvo run --video DRIVE.mp4 --calib {printable(out)}{height} --out runs/DRIVE  "
          f"(frames of {w}x{h})")
    return 0


def _add_calibrate(sub: argparse._SubParsersAction) -> None:
    from flowvo.calibration.board import BOARD_KINDS, DEFAULT_DICTIONARY
    from flowvo.calibration.calibrate import CALIBRATION_MODELS
    from flowvo.calibration.images import DEFAULT_VIDEO_EVERY

    p = sub.add_parser("calibrate", help="intrinsics and lens distortion from a checkerboard or ChArUco video or "
                                         "image folder: writes the YAML 'flowvo run --calib' reads")
    p.add_argument("input", help="a folder of images (png, jpg, bmp, tif) or a video of the board")
    p.add_argument("--out", required=True, help="calibration file to write (ROS camera_calibration YAML)")
    p.add_argument("--board", choices=BOARD_KINDS, default="checkerboard", help="board kind")
    p.add_argument("--rows", type=_bounded(int, 2, 1000), required=True,
                   help="checkerboard: inner corners down a column (a board of 7 rows of squares has 6); "
                        "ChArUco: squares")
    p.add_argument("--cols", type=_bounded(int, 2, 1000), required=True,
                   help="checkerboard: inner corners along a row; ChArUco: squares")
    p.add_argument("--square", type=POSITIVE_FLOAT, metavar="M",
                   help="side of a square in metres (needed for ChArUco; a checkerboard's intrinsics do not "
                        "depend on it)")
    p.add_argument("--marker", type=POSITIVE_FLOAT, metavar="M", help="ChArUco: side of a marker in metres")
    p.add_argument("--dictionary", default=DEFAULT_DICTIONARY, help="ChArUco: OpenCV ArUco dictionary name")
    p.add_argument("--distortion-model", choices=CALIBRATION_MODELS, default="plumb_bob",
                   help="plumb_bob: k1 k2 p1 p2 k3 (most lenses); rational_polynomial: 8 coefficients (wide "
                        "angle); equidistant: k1..k4 (fisheye)")
    p.add_argument("--every", type=POSITIVE_INT, metavar="N",
                   help=f"look at every N-th image (default: every image of a folder, every {DEFAULT_VIDEO_EVERY}th "
                        "frame of a video)")
    p.add_argument("--camera-height", type=_bounded(float, 0.0, 10.0, low_open=True), metavar="M",
                   help="the camera's height above the road in metres, recorded in the file for the road scale")
    p.add_argument("--camera-name", default="camera", help="camera_name in the file (ROS camera_info_manager)")
    _force_flag(p, "an existing --out file")
    p.set_defaults(func=_cmd_calibrate)


SUBCOMMANDS: list[Callable[[argparse._SubParsersAction], None]] = [
    _add_demo, _add_eval, _add_synth, _add_flow, _add_train, _add_run, _add_batch, _add_export, _add_report,
    _add_bench, _add_calibrate,
]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command."""
    parser = _Parser(prog="flowvo", description="Geometry-first monocular visual odometry from dense optical flow, "
                     "with metric scale from the road and the camera height; the thesis network by name "
                     "(--method cnn).")
    parser.add_argument("--version", action="version", version=f"flowvo {__version__}")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in SUBCOMMANDS:
        add(sub)
    for command in sub.choices.values():
        command.add_argument("-q", "--quiet", dest="quiet_here", action="store_true", help="no progress bars")
        command.formatter_class = _DefaultsFormatter
    return parser


RESUMABLE_COMMANDS = ("synth", "flow", "train", "batch")  # a rerun reuses their finished chunks, frames,
# epochs and drives
EXIT_INTERRUPTED, EXIT_TERMINATED = 130, 143  # the shell's 128 + SIGINT, 128 + SIGTERM


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so that every ``finally`` and context manager runs (a render
    pool is stopped, a lock released) before the one-line exit."""


def _raise_terminated(signum: int, frame: object) -> None:
    raise Terminated


def _interrupted(error: BaseException) -> bool:
    """True when ``error`` is, or was raised while handling, a Ctrl-C (an import cut short by Ctrl-C
    raises a RuntimeError of its own)."""
    seen: set[int] = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        if isinstance(current, KeyboardInterrupt):
            return True
        seen.add(id(current))
        current = current.__cause__ or current.__context__
    return False


def _stopped_line(command: str, how: str) -> str:
    kept = "resumable state kept" if command in RESUMABLE_COMMANDS \
        else "nothing to resume: files are written whole, an earlier result is left as it was"
    return f"flowvo {command}: {how} ({kept})"


def main(argv: list[str] | None = None) -> int:
    """Entry point: returns the exit code (2 for bad input, with one line on stderr)."""
    args = build_parser().parse_args(argv)
    if args.quiet or args.quiet_here:
        set_progress_enabled(False)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        return args.func(args)
    except FlowvoError as error:
        print(f"flowvo {args.command}: error: {error}", file=sys.stderr)
        return 2
    except Terminated:
        print(_stopped_line(args.command, "terminated"), file=sys.stderr)
        return EXIT_TERMINATED
    except BrokenPipeError:  # the reader of stdout went away (`flowvo eval ... | head`): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except OSError as error:  # permission denied, read-only, disk full, a file where a folder should be
        if _interrupted(error):
            print(_stopped_line(args.command, "interrupted"), file=sys.stderr)
            return EXIT_INTERRUPTED
        where = f"{error.filename}: " if error.filename else ""
        print(f"flowvo {args.command}: error: {where}{error.strerror or error}", file=sys.stderr)
        return 2
    except BaseException as error:
        if not _interrupted(error):
            raise
        print(_stopped_line(args.command, "interrupted"), file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, signal.SIG_DFL)


if __name__ == "__main__":
    sys.exit(main())
