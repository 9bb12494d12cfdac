"""Compute or resume a sequence's flow cache: ``flowvo flow``."""

from __future__ import annotations

import argparse

import numpy as np

from flowvo.cli.arguments import FLOW_SCALE, POSITIVE_INT, force_flag
from flowvo.errors import FlowvoError


def command(args: argparse.Namespace) -> int:
    from flowvo.flow.cache import FlowCache
    from flowvo.flow.cache_root import default_cache_root
    from flowvo.flow.registry import create_estimator
    from flowvo.flow.visualize import flow_picture_names, save_flow_pictures
    from flowvo.io.outputs import prepare_output_dir
    from flowvo.kitti.sequence import KittiSequence

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


def add_parser(sub: argparse._SubParsersAction) -> None:
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
    force_flag(p, "earlier pictures in --visualize")
    p.set_defaults(func=command)
