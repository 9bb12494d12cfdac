"""The one progress-bar helper: library code reports progress only through here, so it can be silenced.

Bars are drawn only when stderr is a terminal (never into a log file or a CI transcript), and never
when switched off by ``FLOWVO_PROGRESS=0`` or the CLI's ``-q``. An iteration without a bar makes no tqdm object:
tqdm's first one creates a lock between processes (a named semaphore), which a batch worker ended while creating
it leaves behind, and Python's resource tracker then reports it at exit.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

from tqdm import tqdm

T = TypeVar("T")

_enabled = os.environ.get("FLOWVO_PROGRESS", "1") != "0"


def set_progress_enabled(enabled: bool) -> None:
    """Turn all flowvo progress bars on or off (the CLI's --quiet turns them off)."""
    global _enabled
    _enabled = enabled


def _visible() -> bool:
    return _enabled and sys.stderr is not None and sys.stderr.isatty()


def progress(items: Iterable[T], desc: str, total: int | None = None, unit: str = "it") -> Iterator[T]:
    """Iterate over ``items`` with a tqdm bar on stderr when progress is enabled and stderr is a terminal."""
    if not _visible():
        return iter(items)
    return iter(tqdm(items, desc=desc, total=total, unit=unit, leave=False, file=sys.stderr))


def progress_bar(desc: str, total: int | None = None, unit: str = "it") -> tqdm:
    """A bar advanced by hand (``update(n)``, ``set_postfix_str(text)``, ``close()``), drawn under the same
    rules as :func:`progress`."""
    return tqdm(desc=desc, total=total, unit=unit, disable=not _visible(), leave=False, file=sys.stderr)
