"""One batch at a time per output folder: an exclusive lock on ``OUT/.flowvo-batch.lock``, held while the
batch runs and released by the operating system when its process ends, however it ends."""

from __future__ import annotations

import fcntl
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from flowvo.errors import FlowvoError

LOCK_NAME = ".flowvo-batch.lock"


@contextmanager
def batch_lock(out: str | Path) -> Iterator[None]:
    """Hold the batch lock of the existing folder ``out``; a FlowvoError when another batch holds it."""
    path = Path(out) / LOCK_NAME
    with open(path, "a") as handle:
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FlowvoError("another flowvo batch is writing here (it holds .flowvo-batch.lock); wait for it "
                              "or choose another --out", out) from None
        try:
            yield
        finally:
            fcntl.flock(handle.fileno(), fcntl.LOCK_UN)
