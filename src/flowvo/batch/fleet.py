"""``flowvo batch`` as a library call: drives in, summary lines out, outputs and summary in one folder.

Layout of ``OUT``: ``drives/NAME/`` (exactly what ``flowvo run`` writes for that drive), ``plots/NAME.png``,
``summary.csv``, ``summary.json``, ``index.html``, ``logs/NAME.log`` (tracebacks of unexpected errors).

Resume: a drive whose folder holds a complete result (:mod:`flowvo.batch.done`) made with the same
settings (those the last summary.json records, and what the drive's run.json records: method, sub-path
lengths, the camera given) is kept, not rerun; any other drive is run afresh in its own folder. A complete
result made with other settings is refused unless ``force`` (which reruns every drive). ``retry_failed``
runs only the drives the last summary marks failed.

``OUT`` is the batch's own: a folder that holds any of the entries a batch writes (:data:`BATCH_ENTRIES`)
but neither a batch's summary.json nor its lock file (``.flowvo-batch.lock``, which stays after the batch)
is refused unless ``force`` (they are someone else's: an index.html, a summary.csv). A batch takes its
lock and writes its summary.json (every drive pending) before any drive runs, so a batch killed at any
point leaves a folder its rerun recognises.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator, Sequence
from contextlib import closing, contextmanager
from functools import partial
from pathlib import Path
from typing import Any

from flowvo.batch.done import DriveOutputs, read_drive_outputs, recorded_difference
from flowvo.batch.index_page import thumbnail_path, write_index, write_thumbnail
from flowvo.batch.lock import LOCK_NAME, batch_lock
from flowvo.batch.processes import run_in_processes
from flowvo.batch.record import DriveSummary, summarize
from flowvo.batch.spec import Drive, check_drive_options, drive_folder, drive_run_options, processing_settings
from flowvo.batch.summary import batch_totals, read_summary, write_summary
from flowvo.batch.worker import PRELOAD_MODULES, run_drive
from flowvo.drive.options import RunOptions
from flowvo.errors import FlowvoError
from flowvo.io.outputs import check_path_text, is_inside, prepare_output_dir, validate_name
from flowvo.progress import progress_bar

SUMMARY_EVERY_S = 5.0  # while running, the summary files are rewritten at most this often (and at the end)
BATCH_ENTRIES = ("summary.json", "summary.csv", "index.html", "drives", "plots", "logs")  # what a batch writes


def default_workers() -> int:
    """One worker per core this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def run_batch(drives: Sequence[Drive], out: str | Path, defaults: RunOptions | None = None,
              workers: int | None = None, ray: str | None = None, retry_failed: bool = False,
              force: bool = False) -> list[DriveSummary]:
    """Run every drive (one worker process each, ``workers`` at a time, default one per core; or as Ray tasks
    with ``ray`` "auto" or a cluster address) and return their summary lines, in the order given.

    ``defaults``: the ``flowvo run`` options of every drive (its ``out`` and source fields are ignored;
    a drive's settings override the rest). A failing drive is a "failed" line, never an exception; the
    summary files are written even when interrupted (KeyboardInterrupt propagates after that). Raises a
    FlowvoError, with nothing written, for bad arguments (an empty ``out``, a file there, a folder holding
    files a batch writes that are not a batch's, without ``force``), results made with other settings
    (without ``force``), an unreachable Ray, or another batch running in ``out``.
    """
    start = time.perf_counter()
    defaults = defaults or RunOptions(out="")
    out = check_path_text(out, "--out")  # '' would be the current folder
    if out.exists() and not out.is_dir():
        raise FlowvoError("--out is a file, expected a folder", out)
    if workers is not None and workers < 1:
        raise FlowvoError(f"--workers must be at least 1, got {workers}")
    options = _checked_options(drives, defaults, out)
    settings = {name: processing_settings(drive_options) for name, drive_options in options.items()}
    previous = read_summary(out) if out.is_dir() else None
    if retry_failed and previous is None:
        raise FlowvoError("--retry-failed: no summary.json of an earlier batch here", out)
    if previous is None and not force:
        _refuse_foreign_entries(out)
    plan = _plan(drives, settings, out, previous or {}, retry_failed, force)
    anything_to_run = any(line is None for line in plan.values())
    with _ray_session(ray if anything_to_run else None) as ray_module:
        prepare_output_dir(out, [], what="--out")
        with batch_lock(out):
            rows = {drive.name: plan[drive.name] or summarize(drive, settings[drive.name], "pending")
                    for drive in drives}
            if ray is None:
                workers = workers or default_workers()
            backend = f"ray {ray}" if ray is not None else f"{workers} local worker process(es)"
            _write(out, rows, 0, start, backend)  # the folder is a batch's from now on, whatever happens next
            _draw_missing_thumbnails(drives, plan, out)
            to_run = [drive for drive in drives if plan[drive.name] is None]
            function = partial(run_drive, defaults=defaults, out=out)
            if ray is None:
                outcomes = run_in_processes(to_run, function, workers, PRELOAD_MODULES)
            else:
                from flowvo.batch.ray_backend import run_on_ray

                outcomes = run_on_ray(ray_module, to_run, function, workers) if to_run else _no_outcomes()
            _collect(outcomes, len(to_run), rows, settings, out, backend, start)
            return list(rows.values())


def _refuse_foreign_entries(out: Path) -> None:
    """Refuse an ``out`` that holds entries a batch would write but was never a batch's (no summary.json, no
    batch lock file): someone else's."""
    if not out.is_dir() or (out / LOCK_NAME).is_file():
        return
    foreign = [name for name in BATCH_ENTRIES if (out / name).exists() or (out / name).is_symlink()]
    if foreign:
        raise FlowvoError(f"holds {', '.join(foreign)} that no flowvo batch wrote here (no summary.json, no "
                          f"{LOCK_NAME}), and a batch would overwrite them; choose another --out, or pass --force to "
                          "replace them", out)


def _checked_options(drives: Sequence[Drive], defaults: RunOptions, out: Path) -> dict[str, RunOptions]:
    """The run options of every drive, after checking names, sources and options before anything runs."""
    if not drives:
        raise FlowvoError("no drives to run")
    options: dict[str, RunOptions] = {}
    intrinsics_checked: dict[tuple, None] = {}
    for drive in drives:
        validate_name(drive.name, "drive")
        if drive.name.casefold() in (name.casefold() for name in options):
            raise FlowvoError(f"two drives are named {drive.name}: each needs its own output folder")
        if Path(drive.path).is_dir() and is_inside(out, drive.path):
            raise FlowvoError(f"--out is inside the drive {drive.path}; results must not be written into the data",
                              out)
        options[drive.name] = drive_run_options(drive, defaults, out)
        check_drive_options(drive, options[drive.name], intrinsics_checked)
    return options


def _plan(drives: Sequence[Drive], all_settings: dict[str, dict[str, Any]], out: Path,
          previous: dict[str, DriveSummary], retry_failed: bool, force: bool) -> dict[str, DriveSummary | None]:
    """For each drive: its kept line (a complete result, or "pending" when ``retry_failed`` leaves it out),
    or None to run it."""
    plan: dict[str, DriveSummary | None] = {}
    changed: list[str] = []
    for drive in drives:
        settings = all_settings[drive.name]
        earlier = previous.get(drive.name)
        outputs = None if force else _complete(drive_folder(out, drive))
        if outputs is not None:
            if earlier is not None and earlier.settings and earlier.settings != settings:
                changed.append(f"{drive.name}: {_first_difference(earlier.settings, settings)}")
            elif (recorded := recorded_difference(outputs.run, settings)) is not None:
                changed.append(f"{drive.name}: {recorded} (its run.json)")
            kept = earlier if earlier is not None and earlier.status == "ok" else None
            plan[drive.name] = summarize(drive, settings, "ok", outputs=outputs, reused=True,
                                         wall_s=kept.wall_s if kept else None,
                                         peak_memory_mib=kept.peak_memory_mib if kept else None)
        elif retry_failed and (earlier is None or earlier.status != "failed"):
            plan[drive.name] = summarize(drive, settings, "pending")
        else:
            plan[drive.name] = None
    if changed:
        raise FlowvoError(f"{len(changed)} drive(s) hold results made with other settings (first: {changed[0]}); "
                          "pass --force to recompute every drive, or choose another --out", out)
    return plan


def _complete(folder: Path) -> DriveOutputs | None:
    try:
        return read_drive_outputs(folder)
    except FlowvoError:
        return None


def _first_difference(before: dict[str, Any], now: dict[str, Any]) -> str:
    key = next(k for k in sorted(set(before) | set(now)) if before.get(k) != now.get(k))
    return f"{key} {before.get(key)!r} -> {now.get(key)!r}"


@contextmanager
def _ray_session(ray: str | None) -> Iterator[Any]:
    """The connected Ray module for ``ray`` (an address or "auto"); None (no Ray) for local processes."""
    if ray is None:
        yield None
        return
    from flowvo.batch.ray_backend import ray_session

    with ray_session(ray) as module:
        yield module


def _draw_missing_thumbnails(drives: Sequence[Drive], plan: dict[str, DriveSummary | None], out: Path) -> None:
    """Path plots of the kept drives whose plot is gone (the plots folder cleared, an older batch)."""
    for drive in drives:
        kept = plan[drive.name]
        if kept is not None and kept.status == "ok" and not thumbnail_path(out, drive.name).is_file():
            complete = _complete(drive_folder(out, drive))
            if complete is not None:
                write_thumbnail(drive, complete, out)


def _collect(outcomes: Iterator[tuple[Drive, Any]], count: int, rows: dict[str, DriveSummary],
             settings: dict[str, dict], out: Path, backend: str, start: float) -> None:
    """Take each finished drive's line into ``rows`` (a lost worker's drive as failed), with a progress bar and
    the summary files rewritten now and then and at the end, also when interrupted."""
    frames_run, failed, last_write, write_s = 0, 0, time.perf_counter(), 0.0
    bar = progress_bar("drives", total=count, unit="drive")
    try:
        with closing(outcomes):
            for drive, outcome in outcomes:
                row = outcome if isinstance(outcome, DriveSummary) else \
                    summarize(drive, settings[drive.name], "failed", outcome.reason)
                rows[drive.name] = row
                frames_run += (row.frames or 0) if row.status == "ok" else 0
                failed += row.status == "failed"
                bar.set_postfix_str(f"{frames_run / (time.perf_counter() - start):.0f} frames/s, {failed} failed",
                                    refresh=False)
                bar.update(1)
                if time.perf_counter() - last_write > max(SUMMARY_EVERY_S, 20 * write_s):  # big fleets: rarer
                    write_s = _write(out, rows, frames_run, start, backend)
                    last_write = time.perf_counter()
    finally:
        bar.close()
        _write(out, rows, frames_run, start, backend)


def _no_outcomes() -> Iterator[tuple[Drive, Any]]:
    """What running no drive gives (Ray is not even connected then)."""
    yield from ()


def _write(out: Path, rows: dict[str, DriveSummary], frames_run: int, start: float, backend: str) -> float:
    """Write summary.json, summary.csv and index.html; returns the seconds it took."""
    began = time.perf_counter()
    lines = list(rows.values())
    totals = batch_totals(lines, frames_run, began - start, backend)
    write_summary(out, lines, totals)
    write_index(out, lines, totals)
    return time.perf_counter() - began
