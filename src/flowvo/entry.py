"""The ``flowvo`` command's entry point: imports the command line (NumPy, SciPy, OpenCV: a second or two)
so that a Ctrl-C during those imports ends as every other interruption does, one line and exit code 130."""

from __future__ import annotations

import sys


def main() -> int:
    """Run ``flowvo.cli.main``; a Ctrl-C before it could take over is one line on stderr, exit 130."""
    try:
        from flowvo.cli import main as cli_main
    except KeyboardInterrupt:
        print("flowvo: interrupted while starting", file=sys.stderr)
        return 130
    return cli_main()
