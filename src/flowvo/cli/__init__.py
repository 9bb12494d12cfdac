"""The ``flowvo`` command line: one module per sub-command (each a thin ``add_parser`` and ``command`` that parse,
call the library and print), the shared drive options in :mod:`flowvo.cli.drive_options`; here the parser and
``main``, which turns every error into one line and an exit code."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading

from flowvo._version import VERSION as __version__
from flowvo.cli import (
    batch,
    bench,
    calibrate,
    demo,
    evaluate,
    export,
    flow,
    report,
    run,
    synth,
    train,
)
from flowvo.cli.arguments import DefaultsFormatter, Parser
from flowvo.errors import FlowvoError
from flowvo.progress import set_progress_enabled

SUBCOMMANDS = (demo, evaluate, synth, flow, train, run, batch, export, report, bench, calibrate)  # in --help's order


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command."""
    parser = Parser(prog="flowvo", description="Geometry-first monocular visual odometry from dense optical flow, "
                     "with metric scale from the road and the camera height; the thesis network by name "
                     "(--method cnn).")
    parser.add_argument("--version", action="version", version=f"flowvo {__version__}")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in SUBCOMMANDS:
        command.add_parser(sub)
    for command in sub.choices.values():
        command.add_argument("-q", "--quiet", dest="quiet_here", action="store_true", help="no progress bars")
        command.formatter_class = DefaultsFormatter
    return parser


RESUMABLE_COMMANDS = ("synth", "flow", "train", "batch")  # a rerun reuses their finished chunks, frames,
# epochs and drives
EXIT_INTERRUPTED, EXIT_TERMINATED = 130, 143  # the shell's 128 + SIGINT, 128 + SIGTERM


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so that every ``finally`` and context manager runs (a render
    pool is stopped, a lock released) before the one-line exit."""


def _raise_terminated(signum: int, frame: object) -> None:
    raise Terminated


def _interrupted(error: BaseException) -> bool:
    """True when ``error`` is, or was raised while handling, a Ctrl-C (an import cut short by Ctrl-C
    raises a RuntimeError of its own)."""
    seen: set[int] = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        if isinstance(current, KeyboardInterrupt):
            return True
        seen.add(id(current))
        current = current.__cause__ or current.__context__
    return False


def _stopped_line(command: str, how: str) -> str:
    kept = "resumable state kept" if command in RESUMABLE_COMMANDS \
        else "nothing to resume: files are written whole, an earlier result is left as it was"
    return f"flowvo {command}: {how} ({kept})"


def main(argv: list[str] | None = None) -> int:
    """Entry point: returns the exit code (2 for bad input, with one line on stderr)."""
    args = build_parser().parse_args(argv)
    if args.quiet or args.quiet_here:
        set_progress_enabled(False)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        return args.func(args)
    except FlowvoError as error:
        print(f"flowvo {args.command}: error: {error}", file=sys.stderr)
        return 2
    except Terminated:
        print(_stopped_line(args.command, "terminated"), file=sys.stderr)
        return EXIT_TERMINATED
    except BrokenPipeError:  # the reader of stdout went away (`flowvo eval ... | head`): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except OSError as error:  # permission denied, read-only, disk full, a file where a folder should be
        if _interrupted(error):
            print(_stopped_line(args.command, "interrupted"), file=sys.stderr)
            return EXIT_INTERRUPTED
        where = f"{error.filename}: " if error.filename else ""
        print(f"flowvo {args.command}: error: {where}{error.strerror or error}", file=sys.stderr)
        return 2
    except BaseException as error:
        if not _interrupted(error):
            raise
        print(_stopped_line(args.command, "interrupted"), file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, signal.SIG_DFL)


