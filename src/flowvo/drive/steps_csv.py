"""``NAME_steps.csv``: what became of each step of a windowed run (:class:`flowvo.odometry.scale_window.StepRecord`),
one row per step in frame order, for a user who weighs the poses (a fusion filter) or wants to see which
stretches rest on the road; and reading it back.

Columns: ``frame`` (the step's end frame, 1-based: frame 0 has no step), ``time_s``, ``length_m``,
``length_log_sigma`` (standard deviation of the natural log of the length: 0.01 is 1 %; above 1 where only
the held speed measured it; empty at a standstill or where nothing did) and ``measured_by`` (what measured
the step itself: "+"-joined from road, ratio and network; "none"; "standstill").
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from flowvo.io.atomic import atomic_open
from flowvo.odometry.scale_window import StepRecord

HEADER = "frame,time_s,length_m,length_log_sigma,measured_by"


def write_steps_csv(path: str | Path, records: Sequence[StepRecord], frames: int) -> None:
    """Write the records of a run over ``frames`` frames (one per step: ``frames - 1``) atomically."""
    if len(records) != frames - 1:
        raise ValueError(f"{len(records)} step records for {frames} frames: need one per step")
    lines = [HEADER] + [f"{frame},{r.time_s:.9f},{r.length_m:.6f},"
                        f"{'' if r.log_sigma is None else f'{r.log_sigma:.6f}'},{r.measured_by}"
                        for frame, r in enumerate(records, start=1)]
    with atomic_open(path) as handle:
        handle.write("\n".join(lines) + "\n")


def read_steps_csv(path: str | Path) -> list[StepRecord]:
    """The step records of a file :func:`write_steps_csv` wrote (values as rounded there); ValueError for a
    file of another layout."""
    lines = Path(path).read_text().splitlines()
    if not lines or lines[0] != HEADER:
        raise ValueError(f"{path}: not a step records file (its first line must be {HEADER!r})")
    records = []
    for line in lines[1:]:
        _, time_s, length_m, log_sigma, measured_by = line.split(",")
        records.append(StepRecord(float(time_s), float(length_m), float(log_sigma) if log_sigma else None, measured_by))
    return records
