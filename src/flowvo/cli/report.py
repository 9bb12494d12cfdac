"""One HTML page comparing run folders: ``flowvo report``."""

from __future__ import annotations

import argparse

from flowvo.cli.arguments import SUB_PATH_M, force_flag


def command(args: argparse.Namespace) -> int:
    from flowvo.report.page import write_report

    lengths_m = tuple(sorted(set(args.lengths))) if args.lengths else None
    print(f"report: {write_report(args.runs, args.out, args.force, lengths_m)}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("report", help="one HTML page comparing run folders: tables, paths, error curves, timing")
    p.add_argument("runs", nargs="+", help="output folders of 'flowvo run'")
    p.add_argument("--out", required=True, help="report folder (index.html + PNGs)")
    p.add_argument("--lengths", nargs="+", type=SUB_PATH_M, metavar="M",
                   help="sub-path lengths in metres to score (default: each run's own --lengths, from run.json)")
    force_flag(p, "an earlier report in --out")
    p.set_defaults(func=command)
