"""The ``flowvo`` command line: thin sub-commands that parse, call the library and print."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from flowvo import __version__
from flowvo.errors import FlowvoError
from flowvo.progress import set_progress_enabled

Command = Callable[[argparse.Namespace], int]


def _cmd_eval(args: argparse.Namespace) -> int:
    from flowvo.evaluation import evaluate_files, format_table, save_evaluation

    evaluation = evaluate_files(args.gt, args.pred, args.align)
    print(format_table(evaluation.metrics))
    if args.out:
        written = save_evaluation(evaluation, args.out)
        print(f"\nwrote {len(written)} files to {args.out} (metrics.json, plots)")
    return 0


def _add_eval(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("eval", help="score a KITTI pose file against ground truth (KITTI metric, ATE, RPE)")
    p.add_argument("--gt", required=True, help="ground-truth KITTI pose file")
    p.add_argument("--pred", required=True, help="predicted KITTI pose file (12 floats, or frame index + 12)")
    p.add_argument("--align", choices=("none", "6dof", "7dof"), default="none", help="alignment for ATE only")
    p.add_argument("--out", help="folder for metrics.json, per_frame_errors.csv and PNG plots")
    p.set_defaults(func=_cmd_eval)


SUBCOMMANDS: list[Callable[[argparse._SubParsersAction], None]] = [_add_eval]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command."""
    parser = argparse.ArgumentParser(prog="flowvo", description="Learned visual odometry from dense optical flow.")
    parser.add_argument("--version", action="version", version=f"flowvo {__version__}")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in SUBCOMMANDS:
        add(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point: returns the exit code (2 for bad input, with one line on stderr)."""
    args = build_parser().parse_args(argv)
    if args.quiet:
        set_progress_enabled(False)
    try:
        return args.func(args)
    except FlowvoError as error:
        print(f"flowvo {args.command}: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
