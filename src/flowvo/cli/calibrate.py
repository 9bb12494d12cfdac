"""Intrinsics and lens distortion from a board: ``flowvo calibrate``."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from flowvo.cli.arguments import POSITIVE_FLOAT, POSITIVE_INT, bounded, force_flag


def command(args: argparse.Namespace) -> int:
    from flowvo.calibration.board import Board
    from flowvo.calibration.calibrate import COEFFICIENT_NAMES, calibrate, named
    from flowvo.calibration.files import format_ros_calibration
    from flowvo.calibration.images import open_calibration_images, printable
    from flowvo.io.atomic import write_text_atomic
    from flowvo.io.outputs import prepare_output_file

    board = Board(args.board, args.rows, args.cols, args.square, args.marker, args.dictionary)
    images = open_calibration_images(args.input, args.every)
    out = Path(args.out)
    if not (args.force and out.is_file()):  # with --force an earlier file stays until the new one replaces it
        prepare_output_file(out)
    result = calibrate(images.frames(), board, args.distortion_model, images.count)
    i, d = result.intrinsics, result.distortion
    h, w = result.image_size_hw
    print(f"board: {board.describe()}")
    images = f"{result.images_seen} images" if not result.skipped_for_size else \
        f"the {result.images_seen} {w}x{h} images ({len(result.skipped_for_size)} of another size skipped, see below)"
    print(f"found in {result.views_found} of {images}; {result.views_used} distinct views used "
          f"(corners cover {result.coverage:.0%} of the image, board normals span {result.tilt_spread_deg:.0f} deg)")
    if result.without_board:
        print(f"board not found in {len(result.without_board)}: {named(result.without_board)}")
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


def add_parser(sub: argparse._SubParsersAction) -> None:
    from flowvo.calibration.board import BOARD_KINDS, DEFAULT_DICTIONARY
    from flowvo.calibration.calibrate import CALIBRATION_MODELS
    from flowvo.calibration.images import DEFAULT_VIDEO_EVERY

    p = sub.add_parser("calibrate", help="intrinsics and lens distortion from a checkerboard or ChArUco video or "
                                         "image folder: writes the YAML 'flowvo run --calib' reads")
    p.add_argument("input", help="a folder of images (png, jpg, bmp, tif) or a video of the board")
    p.add_argument("--out", required=True, help="calibration file to write (ROS camera_calibration YAML)")
    p.add_argument("--board", choices=BOARD_KINDS, default="checkerboard", help="board kind")
    p.add_argument("--rows", type=bounded(int, 2, 1000), required=True,
                   help="checkerboard: inner corners down a column (a board of 7 rows of squares has 6); "
                        "ChArUco: squares")
    p.add_argument("--cols", type=bounded(int, 2, 1000), required=True,
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
    p.add_argument("--camera-height", type=bounded(float, 0.0, 10.0, low_open=True), metavar="M",
                   help="the camera's height above the road in metres, recorded in the file for the road scale")
    p.add_argument("--camera-name", default="camera", help="camera_name in the file (ROS camera_info_manager)")
    force_flag(p, "an existing --out file")
    p.set_defaults(func=command)
