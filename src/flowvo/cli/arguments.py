"""What every sub-command shares: bounded number types, the help formatter that shows defaults, one-line usage errors,
and ``--force``."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def bounded(kind: type, low: float, high: float = math.inf, low_open: bool = False) -> Callable[[str], float]:
    """An argparse ``type=``: a finite ``kind`` (int or float) in [low, high] ((low, high] if ``low_open``)."""
    def parse(text: str) -> float:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {'an integer' if kind is int else 'a number'}, "
                                             f"got {text!r}") from None
        if not math.isfinite(value) or value < low or (low_open and value == low) or value > high:
            interval = f"{'(' if low_open else '['}{low:g}, {high:g}]"
            raise argparse.ArgumentTypeError(f"{text} is outside {interval}")
        return value

    parse.__name__ = kind.__name__  # argparse names the type in its messages
    return parse


POSITIVE_INT = bounded(int, 1)
NON_NEGATIVE_INT = bounded(int, 0)
FRAME_COUNT = bounded(int, 2)  # a sequence needs two frames for one motion
FLOW_SCALE = bounded(float, 0.0, 2.0, low_open=True)
IMAGE_SCALE = bounded(float, 0.0, 4.0, low_open=True)
POSITIVE_FLOAT = bounded(float, 0.0, 1e6, low_open=True)
SUB_PATH_M = bounded(float, 1.0, 1e5)  # shorter sub-paths measure one frame's noise, not drift (1e-30 m: 1e31 %)



class DefaultsFormatter(argparse.HelpFormatter):
    """``--help`` shows every option's default, unless the help already says it or there is none."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if default in (None, False, argparse.SUPPRESS) or "default" in text or not action.option_strings:
            return text
        shown = " ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in default) \
            if isinstance(default, list | tuple) else default
        return f"{text} (default: {shown})".replace("%", "%%") if "%" not in text else text


class Parser(argparse.ArgumentParser):
    """Usage errors as one line on stderr (exit 2), like every other flowvo error."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def force_flag(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--force", action="store_true", help=f"replace {what} (otherwise an existing one is refused)")
