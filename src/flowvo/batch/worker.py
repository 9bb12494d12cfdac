"""One drive in a worker process (or in the caller's, for a scheduler of one's own): single-threaded native
code, ``flowvo run`` into the drive's own folder, its summary line with wall time and peak memory.

A drive's failure never raises here: it becomes a "failed" line with a one-line error (an unexpected
exception's traceback also goes to ``OUT/logs/NAME.log``).
"""

from __future__ import annotations

import logging
import os
import resource
import shutil
import sys
import time
import traceback
from pathlib import Path

from flowvo.batch.done import read_drive_outputs
from flowvo.batch.record import DriveSummary, summarize
from flowvo.batch.spec import Drive, drive_folder, drive_run_options, processing_settings
from flowvo.drive.options import RunOptions
from flowvo.errors import FlowvoError
from flowvo.io.atomic import write_text_atomic
from flowvo.progress import set_progress_enabled

# Imported once by the local fork server, so each drive's fresh process starts with them loaded.
PRELOAD_MODULES = ("numpy", "cv2", "torch", "matplotlib.pyplot", "flowvo.drive.run",
                   "flowvo.methods.flowvo", "flowvo.drive.stream", "flowvo.report.plots")
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")  # for pools started later
_MAX_ERROR_CHARS = 500


def run_drive(drive: Drive, defaults: RunOptions, out: str | Path) -> DriveSummary:
    """Run ``drive`` with ``defaults`` (see :func:`drive_run_options`) into ``OUT/drives/NAME``, replacing
    whatever that folder held, then draw its path thumbnail; returns its summary line."""
    from flowvo.batch.index_page import write_thumbnail
    from flowvo.drive.run import run

    limit_threads()
    set_progress_enabled(False)
    package_log = logging.getLogger("flowvo")  # warnings go to run.json and the summary, not onto the terminal
    if not any(isinstance(handler, logging.NullHandler) for handler in package_log.handlers):  # from every worker
        package_log.addHandler(logging.NullHandler())
    options = drive_run_options(drive, defaults, out)
    folder = drive_folder(out, drive)
    log = Path(out) / "logs" / f"{drive.name}.log"
    log.unlink(missing_ok=True)
    _reset_peak_memory()
    start = time.perf_counter()
    status, error, outputs = "ok", None, None
    try:
        if folder.exists():  # a partial result, or one being replaced: this drive's own folder only
            shutil.rmtree(folder)
        run(options)
        outputs = read_drive_outputs(folder)
        write_thumbnail(drive, outputs, out)
    except FlowvoError as failure:
        status, error = "failed", one_line(str(failure))
    except Exception as failure:  # a bug or a library's crash on odd data: this drive fails, the batch goes on
        status, error = "failed", one_line(f"{type(failure).__name__}: {failure}")
        write_text_atomic(log, traceback.format_exc())
    return summarize(drive, processing_settings(options), status, error, outputs, time.perf_counter() - start,
                     peak_memory_mib())


def one_line(text: str) -> str:
    """``text`` on one line (line breaks become ' | '), at most 500 characters."""
    flat = " | ".join(line.strip() for line in text.strip().splitlines() if line.strip())
    return flat if len(flat) <= _MAX_ERROR_CHARS else flat[: _MAX_ERROR_CHARS - 3] + "..."


def limit_threads() -> None:
    """One thread per native pool (OpenMP, BLAS, OpenCV, torch): a worker uses one core's worth of them,
    so N workers fit N cores. (The odometry stream keeps its reader thread, which overlaps decoding.)"""
    import cv2
    import torch
    from threadpoolctl import threadpool_limits

    for variable in THREAD_VARIABLES:
        os.environ[variable] = "1"
    cv2.setNumThreads(1)
    torch.set_num_threads(1)
    threadpool_limits(limits=1)


def _reset_peak_memory() -> None:
    """Start the peak-memory count afresh (Linux; a reused worker, e.g. Ray's, then reports this drive only)."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        pass


def peak_memory_mib() -> float | None:
    """This process's peak resident memory in MiB since the last reset (Linux), else since it started."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except (OSError, ValueError, IndexError):
        pass
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux, bytes on macOS
    return peak / (1024.0 * 1024.0 if sys.platform == "darwin" else 1024.0)
