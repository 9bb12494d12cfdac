"""Atomic file writes: write to a temporary file beside the target, then rename it into place.

A crash never leaves a half-written output that later reads as valid.
"""

from __future__ import annotations

import json
import math
import numbers
import os
import signal
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any


def _default_permissions(path: str) -> None:
    """mkstemp creates files readable by the owner only; give them the usual umask-based mode."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, 0o666 & ~umask)


@contextmanager
def _interrupts_held() -> Iterator[None]:
    """Ctrl-C (SIGINT) held back, where the platform and thread allow it (POSIX, main thread), and delivered
    once the block ends: a temporary file is created and its name kept before an interruption can land
    between the two and leave the file behind (seen once in 2-worker ``flowvo synth`` runs)."""
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _named(error: OSError, target: Path) -> OSError:
    """``error`` naming ``target`` when it names no file (a full disk fails a write(), which has none)."""
    if error.filename is None:
        return type(error)(error.errno, error.strerror or str(error), str(target))
    return error


@contextmanager
def atomic_open(path: str | Path, mode: str = "w") -> Iterator[IO[Any]]:
    """Open a temporary file for writing that replaces ``path`` only when the block succeeds."""
    with atomic_path(path) as tmp, open(tmp, mode) as handle:
        yield handle
        handle.flush()
        os.fsync(handle.fileno())


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically."""
    with atomic_open(path, "w") as handle:
        handle.write(text)


def strict_json_value(data: Any) -> Any:
    """``data`` with every NaN or infinite number replaced by None (JSON ``null``) and NumPy scalars made
    Python numbers: JSON has no NaN, and ``NaN`` in a file breaks strict parsers (jq, browsers)."""
    if isinstance(data, dict):
        return {key: strict_json_value(value) for key, value in data.items()}
    if isinstance(data, (list, tuple)):
        return [strict_json_value(value) for value in data]
    if isinstance(data, bool) or not isinstance(data, numbers.Real):
        return data
    if isinstance(data, numbers.Integral):
        return int(data)  # also NumPy integers, which json cannot write
    return float(data) if math.isfinite(data) else None


def strict_json_dumps(data: Any, **kwargs: Any) -> str:
    """``json.dumps`` of :func:`strict_json_value` with ``allow_nan=False``: always valid JSON."""
    return json.dumps(strict_json_value(data), allow_nan=False, **kwargs)


def write_json_atomic(path: str | Path, data: Any) -> None:
    """Write ``data`` as indented, strictly valid JSON (NaN and infinity as null) atomically."""
    write_text_atomic(path, strict_json_dumps(data, indent=2, sort_keys=False) + "\n")


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path for a writer that needs a file name (savefig, np.save, cv2.imwrite).

    The temporary name keeps the target's suffix so format detection by extension still works.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp_name = None
    try:
        with _interrupts_held():  # the name is kept before a Ctrl-C can land, and the cleanup below sees it
            fd, tmp_name = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=target.suffix, dir=target.parent)
        os.close(fd)
        yield Path(tmp_name)
        _default_permissions(tmp_name)
        os.replace(tmp_name, target)
    except OSError as error:
        if tmp_name is not None and os.path.exists(tmp_name):
            os.unlink(tmp_name)
        raise _named(error, target) from None
    except BaseException:
        if tmp_name is not None and os.path.exists(tmp_name):
            os.unlink(tmp_name)
        raise
