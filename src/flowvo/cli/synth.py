"""Render synthetic driving sequences in the KITTI layout: ``flowvo synth``."""

from __future__ import annotations

import argparse

from flowvo.cli.arguments import FRAME_COUNT, IMAGE_SCALE, NON_NEGATIVE_INT, bounded


def command(args: argparse.Namespace) -> int:
    from flowvo.camera import LensDistortion
    from flowvo.synth.dataset import synthesize
    from flowvo.synth.synth_camera import SynthCamera

    camera = SynthCamera(args.camera_height, args.fov, LensDistortion(args.distortion_model, tuple(args.distortion)),
                         args.fps, args.camera_pitch, bonnet_rows=args.bonnet, roll_deg=args.camera_roll,
                         readout_ms=args.readout_ms)
    folders = synthesize(args.out, args.sequences, args.seed, args.frames, args.trajectory, args.scale,
                         args.scene, args.gt_flow, args.workers, args.max_speed, args.force, camera,
                         args.ground_texture_scale)
    for folder in folders:
        print(f"wrote {folder} (synthetic)")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    from flowvo.camera import KITTI_CAMERA_HEIGHT_M, MAX_CAMERA_PITCH_DEG, MAX_CAMERA_ROLL_DEG, MAX_READOUT_MS
    from flowvo.synth.bonnet import MAX_BONNET_ROWS
    from flowvo.synth.synth_camera import PATH_RATE_HZ
    from flowvo.synth.textures import GROUND_TEXTURE_SCALE_RANGE
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
    p.add_argument("--ground-texture-scale", type=bounded(float, *GROUND_TEXTURE_SCALE_RANGE), default=1.0,
                   metavar="F", help="the road's and the grass's texture F times finer (default 1): a camera 1/F times "
                                     "as high sees it in pixels as KITTI's camera sees the default")
    camera = p.add_argument_group("camera (default KITTI's; calib.txt records what flowvo run needs)")
    camera.add_argument("--camera-height", type=bounded(float, 0.0, 10.0, low_open=True),
                        default=KITTI_CAMERA_HEIGHT_M, metavar="M",
                        help="camera height above the road in metres (default 1.65)")
    camera.add_argument("--camera-pitch", type=bounded(float, -MAX_CAMERA_PITCH_DEG, MAX_CAMERA_PITCH_DEG),
                        default=0.0, metavar="DEG", help="camera pitched down by DEG degrees (default 0: level)")
    camera.add_argument("--camera-roll", type=bounded(float, -MAX_CAMERA_ROLL_DEG, MAX_CAMERA_ROLL_DEG),
                        default=0.0, metavar="DEG",
                        help="camera rolled by DEG degrees about its optical axis after its pitch, right side down "
                             "(default 0)")
    camera.add_argument("--readout-ms", type=bounded(float, 0.0, MAX_READOUT_MS), default=0.0, metavar="MS",
                        help="a rolling shutter: each frame's rows exposed top to bottom over MS milliseconds "
                             "(default 0: a global shutter)")
    camera.add_argument("--fov", type=bounded(float, 20.0, 150.0), metavar="DEG",
                        help="horizontal field of view in degrees (default KITTI's focal length, ~81.6)")
    camera.add_argument("--distortion", "--dist", nargs="+", type=float, default=[], metavar="K",
                        help="lens distortion: k1 k2 p1 p2 [k3] (plumb_bob) or k1 k2 k3 k4 (equidistant)")
    camera.add_argument("--distortion-model", choices=("plumb_bob", "equidistant"), default="plumb_bob",
                        help="lens model of --distortion (default plumb_bob)")
    camera.add_argument("--fps", type=bounded(float, 1.0, 120.0), default=PATH_RATE_HZ, metavar="HZ",
                        help="frame rate: the same drive sampled at HZ (default 10, KITTI's); times.txt follows")
    camera.add_argument("--bonnet", type=bounded(float, 0.0, MAX_BONNET_ROWS), default=0.0, metavar="SHARE",
                        help="a car's bonnet, fixed to the camera, over the bottom SHARE of the image height (its top "
                             "edge curves a little; e.g. 0.08; default 0: none)")
    p.add_argument("--workers", type=bounded(int, 1, 64), help="render processes (default: all cores, at most 8)")
    p.add_argument("--max-speed", type=bounded(float, 0.0, 100.0, low_open=True), default=25.0,
                   help="generated paths: top speed in m/s")
    p.add_argument("--force", action="store_true",
                   help="write into a non-empty --out: sequences rendered differently before are replaced whole, "
                        "other content is kept (without it a non-empty --out is refused, except to resume)")
    p.set_defaults(func=command)
