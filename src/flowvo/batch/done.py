"""Whether a drive's output folder holds a complete ``flowvo run`` result, checked rather than assumed.

Complete: run.json and timing.json parse, the KITTI pose file run.json names parses with run.json's
frame count, the TUM file has one pose per frame with increasing times, and the files run.json names
parse: the step records (one per step), the evaluation's metrics.json (a JSON object) and the MCAP (its
summary section, written last, is there and counts one message per frame and topic, where the ``mcap``
library is installed; else the file is not empty). The numbers of the fleet summary are read from these
same files (:func:`flowvo.report.drive_summary.drive_summary` for distance, speeds and heading change).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from flowvo.errors import FlowvoError
from flowvo.io.outputs import validate_name
from flowvo.kitti.poses import read_kitti_poses
from flowvo.report.drive_summary import drive_summary


@dataclass(frozen=True)
class DriveOutputs:
    """What a complete drive result says: ``frames``; ``duration_s``, the seconds between its first and last
    frame; ``path_length_m``, the summed steps between camera centres; ``mean_speed_mps`` and
    ``top_speed_mps`` (the fastest 1 s) and ``heading_change_deg`` (net, left positive), as
    :func:`flowvo.report.drive_summary.drive_summary` defines them; the KITTI metric where ground truth
    exists (else None); the odometry stream's ``frames_per_second``; the ``method``; ``unscaled_steps``, the
    moving steps no measurement of the scale reached (windowed methods, else None); and the poses' camera
    centres ``positions_m`` (N, 3) in the first camera's frame; ``warnings``: what reading the drive worked
    around (run.json's); ``run``: run.json itself."""

    frames: int
    duration_s: float
    path_length_m: float
    mean_speed_mps: float
    top_speed_mps: float
    heading_change_deg: float
    t_err_percent: float | None
    r_err_deg_per_m: float | None
    frames_per_second: float | None
    method: str
    unscaled_steps: int | None
    positions_m: np.ndarray
    warnings: tuple[str, ...] = ()
    run: dict = field(default_factory=dict)


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
    if summary.get("steps"):
        _check_steps(folder / summary["steps"], frames)
    if summary.get("mcap"):
        _check_mcap(folder / summary["mcap"], frames)
    metrics = summary.get("metrics") or {}
    if metrics:
        metrics_path = folder / f"eval_{poses_path.stem}" / "metrics.json"
        if not metrics_path.is_file():
            raise FlowvoError(f"eval_{poses_path.stem}/metrics.json is missing", folder)
        _read_json(metrics_path)
    try:
        drive = drive_summary(trajectory.T_world_cam, times_s)
    except FlowvoError as error:
        raise FlowvoError(error.message, poses_path.with_suffix(".tum")) from None
    positions_m = trajectory.T_world_cam[:, :3, 3]
    warnings = summary.get("warnings") or []
    return DriveOutputs(
        frames=frames,
        duration_s=drive["duration_s"],
        path_length_m=drive["distance_m"],
        mean_speed_mps=drive["mean_speed_mps"],
        top_speed_mps=drive["top_speed_mps"],
        heading_change_deg=drive["heading_change_deg"],
        t_err_percent=_number(metrics.get("t_err_percent")),
        r_err_deg_per_m=_number(metrics.get("r_err_deg_per_m")),
        frames_per_second=_number(summary.get("frames_per_second")),
        method=str(summary.get("method")),
        unscaled_steps=_count((summary.get("scale_window") or {}).get("unscaled_steps")),
        positions_m=positions_m,
        warnings=tuple(str(w) for w in warnings) if isinstance(warnings, list) else (),
        run=summary,
    )


def _check_steps(path: Path, frames: int) -> None:
    """The step records parse, one per step."""
    from flowvo.drive.steps_csv import read_steps_csv

    try:
        records = read_steps_csv(path)
    except (OSError, UnicodeDecodeError, ValueError):
        raise FlowvoError("is not a step records file (damaged?)", path) from None
    if len(records) != frames - 1:
        raise FlowvoError(f"has {len(records)} step records; run.json's {frames} frames have {frames - 1} steps",
                          path)


def _check_mcap(path: Path, frames: int) -> None:
    """The odometry MCAP has its summary (written last, so a file cut short has none) counting one odometry
    and one /tf message per frame and the path once; without the ``mcap`` library, that it is not empty."""
    try:
        from mcap.reader import make_reader
    except ImportError:
        if path.stat().st_size == 0:
            raise FlowvoError("is empty", path) from None
        return
    try:
        with open(path, "rb") as handle:
            summary = make_reader(handle).get_summary()
    except Exception:  # the mcap library raises its own errors (and struct's) for a damaged file
        summary = None
    if summary is None or summary.statistics is None:
        raise FlowvoError("is not a complete MCAP file (cut short?)", path)
    if summary.statistics.message_count != 2 * frames + 1:
        raise FlowvoError(f"holds {summary.statistics.message_count} messages; {frames} frames need "
                          f"{2 * frames + 1}", path)


def _read_json(path: Path) -> dict:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise FlowvoError("missing", path) from None
    except OSError as error:  # a folder where the file should be, or a file where the folder should be
        raise FlowvoError(f"unreadable: {error.strerror or error}", path) from None
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
    if np.any(np.diff(table[:, 0]) <= 0):
        raise FlowvoError("times do not increase", path)
    return table[:, 0]


def _number(value: object) -> float | None:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) \
        and math.isfinite(value) else None


def _count(value: object) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) and value >= 0 else None


def recorded_difference(run: dict[str, Any], settings: dict[str, Any]) -> str | None:
    """The first of ``settings`` (:func:`flowvo.batch.spec.processing_settings`) that a drive's run.json
    ``run`` records otherwise, as "NAME recorded -> asked"; None when all it records agree (the method,
    the evaluation's sub-path lengths, the classical method's scale, the camera height, pitch, roll, readout time,
    distortion and intrinsics given, whether intrinsics were given at all, a frame limit)."""
    from flowvo.camera import LensDistortion

    camera = run.get("camera") if isinstance(run.get("camera"), dict) else {}
    checks: list[tuple[str, Any, Any]] = [("method", run.get("method"), settings.get("method")),
                                          ("lengths_m", run.get("lengths_m"), settings.get("lengths_m"))]
    if settings.get("method") == "classical":
        checks.append(("classical_scale", run.get("scale_source"), settings.get("classical_scale")))
    for name in ("camera_height_m", "camera_pitch_deg", "camera_roll_deg", "readout_ms"):
        if settings.get(name) is not None:
            checks.append((name, camera.get(name), settings[name]))
    if settings.get("distortion") is not None:
        asked = LensDistortion(settings.get("distortion_model") or "plumb_bob", tuple(settings["distortion"]))
        checks.append(("distortion", camera.get("distortion"), list(asked.coefficients)))
    given = "calib" if settings.get("calib") is not None else "flags" if settings.get("fx") is not None else None
    recorded_source = camera.get("source")
    if given is not None or recorded_source in ("calib", "flags"):
        checks.append(("camera source", recorded_source, given))
    if given == "flags":
        checks.append(("intrinsics", [camera.get(k) for k in ("fx", "fy", "cx", "cy")],
                       [settings.get(k) for k in ("fx", "fy", "cx", "cy")]))
    limit = settings.get("max_frames")
    if limit is not None and isinstance(run.get("frames"), int) and run["frames"] > limit:
        checks.append(("max_frames", f"more than {limit} frames", limit))
    return next((f"{name} {recorded!r} -> {asked!r}" for name, recorded, asked in checks if recorded != asked), None)
