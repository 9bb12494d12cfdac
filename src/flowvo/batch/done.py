"""Whether a drive's output folder holds a complete ``flowvo run`` result, checked rather than assumed.

Complete: run.json and timing.json parse, the KITTI pose file run.json names parses with run.json's
frame count, the TUM file has one pose per frame, and the MCAP, step records and evaluation run.json names
exist. The
numbers of the fleet summary are read from these same files.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flowvo.errors import FlowvoError
from flowvo.io.outputs import validate_name
from flowvo.kitti.poses import read_kitti_poses


@dataclass(frozen=True)
class DriveOutputs:
    """What a complete drive result says: ``frames``; ``duration_s``, the seconds between its first and last
    frame; ``path_length_m``, the summed steps between camera centres; the KITTI metric where ground truth
    exists (else None); the odometry stream's ``frames_per_second``; the ``method``; ``unscaled_steps``, the
    moving steps no measurement of the scale reached (windowed methods, else None); and the poses' camera
    centres ``positions_m`` (N, 3) in the first camera's frame."""

    frames: int
    duration_s: float
    path_length_m: float
    t_err_percent: float | None
    r_err_deg_per_m: float | None
    frames_per_second: float | None
    method: str
    unscaled_steps: int | None
    positions_m: np.ndarray


def read_drive_outputs(folder: str | Path) -> DriveOutputs:
    """The result in ``folder``; raises FlowvoError naming the first missing or damaged file."""
    folder = Path(folder)
    summary = _read_json(folder / "run.json")
    _read_json(folder / "timing.json")
    frames = summary.get("frames")
    if not isinstance(frames, int) or isinstance(frames, bool) or frames < 1 or not isinstance(summary.get("poses"),
                                                                                               str):
        raise FlowvoError("run.json lacks 'frames' (a count) or 'poses' (a file name)", folder / "run.json")
    poses_path = folder / validate_name(summary["poses"], "run.json 'poses' file")
    trajectory = read_kitti_poses(poses_path)
    if len(trajectory) != frames:
        raise FlowvoError(f"has {len(trajectory)} poses; run.json says {frames} frames", poses_path)
    times_s = _tum_times(poses_path.with_suffix(".tum"), frames)
    for key in ("mcap", "steps"):
        if summary.get(key) and not (folder / validate_name(summary[key], f"run.json '{key}' file")).is_file():
            raise FlowvoError(f"{summary[key]} named by run.json is missing", folder)
    metrics = summary.get("metrics") or {}
    if metrics and not (folder / f"eval_{poses_path.stem}" / "metrics.json").is_file():
        raise FlowvoError(f"eval_{poses_path.stem}/metrics.json is missing", folder)
    positions_m = trajectory.T_world_cam[:, :3, 3]
    return DriveOutputs(
        frames=frames,
        duration_s=float(times_s[-1] - times_s[0]),
        path_length_m=float(np.linalg.norm(np.diff(positions_m, axis=0), axis=1).sum()),
        t_err_percent=_number(metrics.get("t_err_percent")),
        r_err_deg_per_m=_number(metrics.get("r_err_deg_per_m")),
        frames_per_second=_number(summary.get("frames_per_second")),
        method=str(summary.get("method")),
        unscaled_steps=_count((summary.get("scale_window") or {}).get("unscaled_steps")),
        positions_m=positions_m,
    )


def _read_json(path: Path) -> dict:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise FlowvoError("missing", path) from None
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise FlowvoError("is not valid JSON (cut short?)", path) from None
    if not isinstance(data, dict):
        raise FlowvoError("expected a JSON object", path)
    return data


def _tum_times(path: Path, frames: int) -> np.ndarray:
    """The timestamps (seconds) of the TUM file, which must hold ``frames`` lines of 8 numbers."""
    try:
        table = np.loadtxt(path, ndmin=2)
    except (OSError, ValueError):
        raise FlowvoError("missing or not a TUM trajectory", path) from None
    if table.shape != (frames, 8) or not np.all(np.isfinite(table)):
        raise FlowvoError(f"expected {frames} lines of 8 numbers, found {table.shape[0]}", path)
    return table[:, 0]


def _number(value: object) -> float | None:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) \
        and math.isfinite(value) else None


def _count(value: object) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) and value >= 0 else None
