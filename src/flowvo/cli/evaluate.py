"""Score a KITTI pose file against ground truth: ``flowvo eval``."""

from __future__ import annotations

import argparse

from flowvo.cli.arguments import SUB_PATH_M, force_flag
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M as DEVKIT_LENGTHS_M


def command(args: argparse.Namespace) -> int:
    from flowvo.io.outputs import prepare_output_dir
    from flowvo.report.evaluation import EVALUATION_FILES, evaluate_files, format_table, save_evaluation

    evaluation = evaluate_files(args.gt, args.pred, args.align, tuple(sorted(set(args.lengths))))
    print(format_table(evaluation.metrics))
    if args.out:
        prepare_output_dir(args.out, EVALUATION_FILES, args.force)
        written = save_evaluation(evaluation, args.out)
        print(f"\nwrote {len(written)} files to {args.out} (metrics.json, plots)")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("eval", help="score a KITTI pose file against ground truth (KITTI metric, ATE, RPE)")
    p.add_argument("--gt", required=True, help="ground-truth KITTI pose file")
    p.add_argument("--pred", required=True, help="predicted KITTI pose file (12 floats, or frame index + 12)")
    p.add_argument("--align", choices=("none", "6dof", "7dof"), default="none", help="alignment for ATE only")
    p.add_argument("--out", help="folder for metrics.json, per_frame_errors.csv and PNG plots")
    p.add_argument("--lengths", nargs="+", type=SUB_PATH_M, default=list(DEVKIT_LENGTHS_M), metavar="M",
                   help="sub-path lengths in metres (default the devkit's 100 200 ... 800; e.g. 10 20 30 40 50 "
                        "for short drives: the output then says the lengths differ)")
    force_flag(p, "an earlier evaluation in --out")
    p.set_defaults(func=command)
