"""The main job on the built-in synthetic drive (or a KITTI sequence): ``flowvo demo``."""

from __future__ import annotations

import argparse

from flowvo.cli.arguments import FRAME_COUNT, bounded, force_flag


def command(args: argparse.Namespace) -> int:
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


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="one command: synthetic drive (or --data), packaged model, baseline, report")
    p.add_argument("--data", help="KITTI root (default: render a synthetic held-out drive)")
    p.add_argument("--sequence", help="sequence of --data")
    p.add_argument("--model", help="checkpoint of the CNN method (default: the packaged model)")
    p.add_argument("--frames", type=FRAME_COUNT, default=900, help="frames of the synthetic drive")
    p.add_argument("--camera-height", type=bounded(float, 0.0, 10.0, low_open=True), metavar="M",
                   help="camera height above the road in metres (default: the sequence's calib.txt, else 1.65)")
    p.add_argument("--out", default="runs/demo", help="output folder")
    force_flag(p, "the runs and report of an earlier demo in --out")
    p.set_defaults(func=command)
