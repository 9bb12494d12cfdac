"""One line of the fleet summary: what became of one drive."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from flowvo.batch.done import DriveOutputs
from flowvo.batch.spec import Drive

STATUSES = ("ok", "failed", "pending")  # pending: not run (interrupted, or left out by --retry-failed)


@dataclass
class DriveSummary:
    """What became of one drive of a batch.

    ``status``: "ok", "failed" (``error``: one line saying why) or "pending" (not run). ``frames``,
    ``duration_s`` (seconds between first and last frame), ``path_length_m``, ``mean_speed_mps``,
    ``top_speed_mps`` (the fastest 1 s), ``heading_change_deg`` (net, left positive), the KITTI metric
    (``t_err_percent``, ``r_err_deg_per_m``, only with ground truth and sub-paths as long as the drive's),
    ``frames_per_second`` (the drive's odometry stream), ``unscaled_steps`` (moving steps no measurement of the
    scale reached; windowed methods), ``warnings`` (what reading the drive worked around, such as a video
    that ended early; one line, '' when none): from its outputs, when ok. ``wall_s``: seconds
    its worker spent on it, start-up included; ``peak_memory_mib``: the worker's peak resident memory (MiB)
    during it. ``reused``: completed by an earlier run of the batch, checked and kept. ``output``: its
    folder, relative to the batch output. ``settings``: the run options that shaped it.
    """

    drive: str
    kind: str
    source: str
    sequence: str | None
    status: str
    error: str | None = None
    method: str | None = None
    frames: int | None = None
    duration_s: float | None = None
    path_length_m: float | None = None
    mean_speed_mps: float | None = None
    top_speed_mps: float | None = None
    heading_change_deg: float | None = None
    t_err_percent: float | None = None
    r_err_deg_per_m: float | None = None
    frames_per_second: float | None = None
    unscaled_steps: int | None = None
    warnings: str | None = None
    wall_s: float | None = None
    peak_memory_mib: float | None = None
    reused: bool = False
    output: str = ""
    settings: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """The fields as a JSON-ready dictionary."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> DriveSummary:
        """From :meth:`as_dict` (extra keys ignored, missing ones default)."""
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in data.items() if k in names})


def summarize(drive: Drive, settings: dict[str, Any], status: str, error: str | None = None,
              outputs: DriveOutputs | None = None, wall_s: float | None = None,
              peak_memory_mib: float | None = None, reused: bool = False) -> DriveSummary:
    """The summary line of ``drive`` (numbers from ``outputs`` when given), rounded for reading."""
    numbers: dict[str, Any] = {}
    if outputs is not None:
        numbers = {"method": outputs.method, "frames": outputs.frames, "duration_s": _round(outputs.duration_s, 3),
                   "path_length_m": _round(outputs.path_length_m, 3),
                   "mean_speed_mps": _round(outputs.mean_speed_mps, 3),
                   "top_speed_mps": _round(outputs.top_speed_mps, 3),
                   "heading_change_deg": _round(outputs.heading_change_deg, 2),
                   "warnings": " | ".join(outputs.warnings) or None,
                   "t_err_percent": _round(outputs.t_err_percent, 4),
                   "r_err_deg_per_m": _round(outputs.r_err_deg_per_m, 6),
                   "frames_per_second": _round(outputs.frames_per_second, 1),
                   "unscaled_steps": outputs.unscaled_steps}
    return DriveSummary(drive=drive.name, kind=drive.kind, source=drive.path, sequence=drive.sequence, status=status,
                        error=error, wall_s=_round(wall_s, 3), peak_memory_mib=_round(peak_memory_mib, 1),
                        reused=reused, output=f"drives/{drive.name}", settings=settings,
                        **{"method": settings.get("method"), **numbers})


def _round(value: float | None, digits: int) -> float | None:
    return None if value is None else round(float(value), digits)
