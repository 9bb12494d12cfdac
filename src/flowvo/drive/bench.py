"""``flowvo bench``: streaming frames per second and seconds per stage of each method on one drive.

Every method runs through the same per-frame step as ``flowvo run`` (:mod:`flowvo.methods`), one
frame at a time as a car's computer would, with frames decoded in a reader thread. Frames per second is
wall-clock over the whole stream; stage seconds are means per frame. Each number is the median of
``repeat`` runs. Before each run, one core decodes the same frames alone: the run's speed over that rate
is the ratio a machine's own decoding sets (paired run by run, so that a machine whose speed drifts
between runs, as shared virtual machines do, still gives a fair ratio), and its median is reported.
"""

from __future__ import annotations

import dataclasses
import json
import time

import cv2
import numpy as np

from flowvo.drive.options import RunOptions, make_step, open_drive
from flowvo.drive.stream import stream_odometry, timing_report
from flowvo.errors import FlowvoError
from flowvo.io.atomic import write_text_atomic
from flowvo.methods import METHODS
from flowvo.methods.stages import STAGES, stage_seconds_text
from flowvo.report.reference_system import REFERENCE_SECONDS_PER_FRAME


def benchmark(options: RunOptions, methods: list[str], frames: int, repeat: int) -> list[dict]:
    """One row per method (in the given order): method, label, frames_per_second, seconds per stage."""
    if frames < 2:
        raise FlowvoError(f"--frames must be at least 2, got {frames}")
    if repeat < 1:
        raise FlowvoError(f"--repeat must be at least 1, got {repeat}")
    rows = []
    for method in methods:
        latency = options.latency_frames if METHODS[method].windowed else None  # --latency: the windowed rows
        method_options = dataclasses.replace(options, method=method, latency_frames=latency)
        reports, decode_rates, label, used = [], [], "", 0
        for _ in range(repeat):
            drive = open_drive(method_options)
            step = make_step(method_options, drive)
            source = drive.source
            decode_rates.append(_decode_pass(options, frames))
            result = stream_odometry(source.frames(), step, min(frames, source.frame_count or frames), frames,
                                     f"bench {method}")
            reports.append(timing_report(result))
            label, used = step.label, result.frames
        rates = [r["frames_per_second"] for r in reports]
        row = {"method": method, "label": label, "frames": used, "repeats": repeat,
               "frames_per_second": float(np.median(rates)),
               "decode_frames_per_second": float(np.median(decode_rates)),
               "over_decoding": float(np.median(np.divide(rates, decode_rates)))}
        for stage in (*STAGES, "total"):
            row[f"{stage}_s"] = float(np.median([r["seconds_per_frame"][stage] for r in reports]))
        rows.append(row)
    return rows


def _decode_pass(options: RunOptions, frames: int) -> float:
    """Frames per second at which one core only decodes the drive's first ``frames`` frames: the ceiling any
    streaming method is measured against."""
    source = open_drive(dataclasses.replace(options, method="classical")).source
    opencv_threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        start, count = time.perf_counter(), 0
        for _, _image in source.frames():
            count += 1
            if count == frames:
                break
        return count / (time.perf_counter() - start)
    finally:
        cv2.setNumThreads(opencv_threads)


def format_bench_table(rows: list[dict]) -> str:
    """The timing table with speed-ups over the reference system."""
    names = ("read", "flow", "network", "geometry", "window", "chain", "total")
    header = f"{'method':62s} " + " ".join(f"{n:>8s}" for n in names) + f" {'fps':>7s} {'vs ref':>7s}"
    lines = [header, "-" * len(header)]
    for row in rows:
        cells = [stage_seconds_text(row["method"], stage, row[f"{stage}_s"]) for stage in STAGES]
        lines.append(f"{row['label'][:62]:62s} " + " ".join(f"{c:>8s}" for c in cells)
                     + f" {row['total_s']:8.4f} {row['frames_per_second']:7.1f}"
                     f" {REFERENCE_SECONDS_PER_FRAME / row['total_s']:6.1f}x")
    lines.append(f"{'reference system (2016), published, GPU':62s} " + " ".join(f"{'':8s}" for _ in STAGES)
                 + f" {REFERENCE_SECONDS_PER_FRAME:8.3f} {1 / REFERENCE_SECONDS_PER_FRAME:7.1f} {'1.0x':>7s}")
    lines.append("seconds per frame (stages: means; read overlaps the rest in its own thread; total: wall clock), "
                 "median of repeated streaming runs")
    lines.append("decoding alone on one core before each run: " + ", ".join(
        f"{row['decode_frames_per_second']:.0f}" for row in rows) + " frames/s; streaming / decoding, paired run by "
        "run: " + ", ".join(f"{row['method']} {row['over_decoding']:.2f}" for row in rows))
    return "\n".join(lines)


def write_bench_json(path: str, rows: list[dict]) -> None:
    """The rows as JSON (default method first, as run; each with its decoding-only rate and its ratio to
    it), atomically."""
    write_text_atomic(path, json.dumps({"rows": rows, "reference_seconds_per_frame": REFERENCE_SECONDS_PER_FRAME},
                                       indent=2) + "\n")
