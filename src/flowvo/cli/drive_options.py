"""The drive, camera and method options of ``run``, ``bench`` and ``batch``, in one place, and the ``RunOptions``
they give."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from flowvo.cli.arguments import bounded
from flowvo.flow.registry import available_methods as available_flow_methods
from flowvo.methods import DEFAULT_METHOD, METHODS, methods_help
from flowvo.odometry.scale_window import LATENCY_FRAMES, MAX_LATENCY_FRAMES

if TYPE_CHECKING:
    from flowvo.drive.options import RunOptions


def add_drive_options(p: argparse.ArgumentParser, methods_default: str | None = DEFAULT_METHOD,
                       one_drive: bool = True) -> None:
    """The drive, camera and method options of ``run``, ``bench`` and ``batch`` (``one_drive`` False: no
    drive options but the bag topics, which apply to every bag of a batch)."""
    from flowvo.camera import MAX_CAMERA_PITCH_DEG, MAX_CAMERA_ROLL_DEG, MAX_READOUT_MS

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
    camera.add_argument("--camera-height", type=bounded(float, 0.0, 10.0, low_open=True), metavar="M",
                        help="camera height above the road in metres (default: the calibration's, else KITTI's 1.65)")
    camera.add_argument("--camera-pitch", type=bounded(float, -MAX_CAMERA_PITCH_DEG, MAX_CAMERA_PITCH_DEG),
                        metavar="DEG", help="the camera points DEG degrees below the road's plane (down positive; "
                                            "default: the calibration's, else 0: mounted level)")
    camera.add_argument("--camera-roll", type=bounded(float, -MAX_CAMERA_ROLL_DEG, MAX_CAMERA_ROLL_DEG),
                        metavar="DEG", help="the camera is rolled DEG degrees about its optical axis after its pitch "
                                            "(right side down positive; default: the calibration's, else 0)")
    camera.add_argument("--readout-ms", type=bounded(float, 0.0, MAX_READOUT_MS), metavar="MS",
                        help="a rolling shutter exposes the frame's last row MS milliseconds after its first (most "
                             "dash-cams and phones; see the camera's data sheet; default: the calibration's, else 0: "
                             "a global shutter, as KITTI's)")
    if methods_default is not None:
        p.add_argument("--method", choices=list(METHODS), default=methods_default, help=methods_help())
    p.add_argument("--model", help="network checkpoint for cnn and flowvo's fallback (default: the packaged model)")
    p.add_argument("--latency", type=bounded(int, 0, MAX_LATENCY_FRAMES), metavar="FRAMES",
                   help=f"flowvo, flowvo-geometry: each pose is final this many frames late (default "
                        f"{LATENCY_FRAMES}; 0: at once, less accurate: docs/results.md)")
    p.add_argument("--flow-method", choices=available_flow_methods(),
                   help="flow method (flowvo: of the road crop, default dis-road; cnn: default the model's)")


def run_options(args: argparse.Namespace, out: str) -> RunOptions:
    """RunOptions from the parsed drive options (see :func:`add_drive_options`)."""
    from flowvo.drive.options import RunOptions

    return RunOptions(out=out, data=getattr(args, "data", None), sequence=getattr(args, "sequence", None),
                      video=getattr(args, "video", None), bag=getattr(args, "bag", None), topic=args.topic,
                      camera_info_topic=args.camera_info_topic, calib=args.calib, fx=args.fx,
                      fy=args.fy, cx=args.cx, cy=args.cy, distortion=tuple(args.dist) if args.dist else None,
                      distortion_model=args.distortion_model, camera_height_m=args.camera_height,
                      camera_pitch_deg=args.camera_pitch, camera_roll_deg=args.camera_roll, readout_ms=args.readout_ms,
                      latency_frames=args.latency,
                      method=getattr(args, "method", DEFAULT_METHOD), model=args.model, flow_method=args.flow_method,
                      classical_scale=getattr(args, "scale_from", "height"),
                      max_frames=getattr(args, "max_frames", None))
