"""Streaming frames/s and seconds per stage: ``flowvo bench``."""

from __future__ import annotations

import argparse

from flowvo.cli.arguments import FRAME_COUNT, POSITIVE_INT, force_flag
from flowvo.cli.drive_options import add_drive_options, run_options
from flowvo.methods import METHODS


def command(args: argparse.Namespace) -> int:
    from flowvo.drive.bench import benchmark, format_bench_table, write_bench_json
    from flowvo.io.outputs import prepare_output_file

    if args.json:  # checked before the benchmark runs: never into the dataset, never over a file unasked
        prepare_output_file(args.json, args.force, "--json", dataset=args.data)
    options = run_options(args, "")
    rows = benchmark(options, args.methods, args.frames, args.repeat)
    print(format_bench_table(rows))
    if args.json:
        write_bench_json(args.json, rows)
        print(f"wrote {args.json}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="streaming frames/s and seconds per stage of each method, median of repeats")
    add_drive_options(p, methods_default=None)
    p.add_argument("--methods", nargs="+", choices=list(METHODS), default=["flowvo", "cnn", "classical"],
                   help="methods in table order (default method first)")
    p.add_argument("--frames", type=FRAME_COUNT, default=200, help="frames per run (at least 2)")
    p.add_argument("--repeat", type=POSITIVE_INT, default=3, help="runs per method; the table shows medians")
    p.add_argument("--json", metavar="PATH", help="also write the rows as JSON")
    force_flag(p, "an existing --json file")
    p.set_defaults(func=command)
