"""Odometry on many drives: ``flowvo batch``."""

from __future__ import annotations

import argparse

from flowvo.cli.arguments import FRAME_COUNT, POSITIVE_FLOAT, POSITIVE_INT
from flowvo.cli.drive_options import add_drive_options, run_options
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M as DEVKIT_LENGTHS_M


def command(args: argparse.Namespace) -> int:
    from flowvo.batch import discover_drives, run_batch
    from flowvo.io.outputs import check_path_text

    check_path_text(args.out, "--out")  # before the search, which skips --out: '' would skip the current folder
    drives = discover_drives(args.inputs, exclude=args.out)
    defaults = run_options(args, args.out)
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
        elif row.warnings:
            print(f"warning: {row.drive}: {row.warnings}")
    print(f"summary: {args.out}/summary.csv, {args.out}/summary.json, {args.out}/index.html")
    return 1 if counts["failed"] else 0


def add_parser(sub: argparse._SubParsersAction) -> None:
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
    add_drive_options(p, one_drive=False)  # every drive; a manifest line overrides them for its drive
    p.add_argument("--scale-from", choices=("height", "gt"), default="height",
                   help="classical method's metric scale: the camera height, or GT step lengths (labelled)")
    p.add_argument("--max-frames", type=FRAME_COUNT, help="stop each drive after this many frames")
    p.add_argument("--lengths", nargs="+", type=POSITIVE_FLOAT, default=list(DEVKIT_LENGTHS_M), metavar="M",
                   help="evaluation sub-path lengths in metres, where ground truth exists (default 100..800)")
    p.add_argument("--mcap", action="store_true", help="also write NAME.mcap per drive (always for bags)")
    p.add_argument("--frame-id", default="odom", help="MCAP parent frame id")
    p.add_argument("--child-frame-id", default="camera_optical", help="MCAP child frame id")
    p.set_defaults(func=command)
