"""One output folder of ``flowvo run``, read back and checked: its summary, timing, poses, the drive's
distance, speeds and heading change (:mod:`flowvo.report.drive_summary`) and, with ground truth, the
evaluation recomputed from the pose file."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flowvo.errors import FlowvoError
from flowvo.io.outputs import validate_name
from flowvo.kitti.poses import read_kitti_poses
from flowvo.kitti.sequence import KittiSequence
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M
from flowvo.report.drive_summary import drive_summary
from flowvo.report.evaluation import Evaluation, evaluate

RUN_KEYS = ("label", "sequence", "data", "synthetic", "frames", "poses")
MIN_FRAMES = 2  # what flowvo run needs and writes
TIMING_STAGES = ("image_read", "flow", "network", "total")
DRIVE_KEYS = ("distance_m", "duration_s", "mean_speed_mps", "top_speed_mps", "heading_change_deg")
TUM_FIELDS = 8  # timestamp tx ty tz qx qy qz qw


@dataclass
class RunRecord:
    """One run folder: its summary, timing, its poses, what the drive did and the evaluation recomputed from
    the poses (None without ground truth)."""

    folder: Path
    summary: dict
    timing: dict
    evaluation: Evaluation | None
    positions: np.ndarray  # (N, 3) camera centres of its pose file, metres
    drive: dict | None = None  # drive_summary of its poses at its timestamps; None for a run without them

    @property
    def kind(self) -> str:
        """What the drive was: synthetic, KITTI (a dataset folder), video or bag."""
        if self.summary["synthetic"]:
            return "synthetic"
        source = self.summary.get("source") if isinstance(self.summary.get("source"), dict) else {}
        return "video" if source.get("video") else "bag" if source.get("bag") else "KITTI"

    @property
    def camera(self) -> dict:
        """run.json's camera record ({} for a run that has none)."""
        camera = self.summary.get("camera")
        return camera if isinstance(camera, dict) else {}


def load_run(folder: str | Path, lengths_m: tuple[float, ...] | None = None) -> RunRecord:
    """Read run.json, timing.json and the poses of a ``flowvo run`` output folder; evaluate on
    ``lengths_m`` (default: the run's own, recorded in run.json, else the devkit's). The drive's numbers
    come from the poses and the TUM file's timestamps (run.json's ``drive`` for a run without a TUM file)."""
    folder = Path(folder)
    summary = _read_record(folder / "run.json", RUN_KEYS)
    if not all(isinstance(summary[key], str) for key in ("label", "sequence", "poses")) \
            or not isinstance(summary["data"], str | None) or not isinstance(summary["synthetic"], bool):
        raise FlowvoError("label, sequence and poses must be text, data text or null, synthetic true or false",
                          folder / "run.json")
    try:
        validate_name(summary["sequence"], "run.json 'sequence'")
    except FlowvoError as error:
        raise FlowvoError(error.message, folder / "run.json") from None
    frames = summary["frames"]
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < MIN_FRAMES:
        raise FlowvoError(f"'frames' must be a whole number of at least {MIN_FRAMES}, got {frames!r}",
                          folder / "run.json")
    lengths_m = lengths_m or _run_lengths(summary, folder / "run.json")
    timing = _read_record(folder / "timing.json", ("seconds_per_frame",))
    seconds = timing["seconds_per_frame"]
    if not isinstance(seconds, dict) or not all(_is_seconds(seconds.get(k)) for k in TIMING_STAGES) \
            or seconds["total"] <= 0:
        raise FlowvoError(f"seconds_per_frame must give {', '.join(TIMING_STAGES)} as seconds (total > 0)",
                          folder / "timing.json")
    evaluation = None
    poses_file = folder / validate_name(summary["poses"], "run.json 'poses' file")
    poses = read_kitti_poses(poses_file)
    sequence = KittiSequence(summary["data"], summary["sequence"]) if summary["data"] else None
    if sequence is not None and sequence.has_poses:
        evaluation = evaluate(sequence.poses, poses, lengths_m=lengths_m)
    tum = poses_file.with_suffix(".tum")
    if tum.is_file():
        drive = drive_summary(poses.T_world_cam, read_tum_times(tum, len(poses))) if len(poses) >= 2 else None
    else:
        drive = _recorded_drive(summary)
    return RunRecord(folder, summary, timing, evaluation, poses.positions, drive)


def read_tum_times(path: Path, count: int) -> np.ndarray:
    """The timestamps (seconds, (count,)) of a TUM trajectory file (``t tx ty tz qx qy qz qw`` a line; lines
    starting with ``#`` are comments) of ``count`` poses, strictly increasing; errors name the file and line."""
    times, number = [], 0
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise FlowvoError("not a TUM trajectory (not UTF-8 text)", path) from None
    except OSError as error:
        raise FlowvoError(f"cannot be read: {error.strerror or error}", path) from None
    for number, line in enumerate(text.splitlines(), 1):
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        if len(fields) != TUM_FIELDS:
            raise FlowvoError(f"expected {TUM_FIELDS} numbers (t tx ty tz qx qy qz qw), found {len(fields)} fields",
                              path, number)
        try:
            time_s = float(fields[0])
        except ValueError:
            raise FlowvoError(f"timestamp {fields[0]!r} is not a number", path, number) from None
        if not np.isfinite(time_s) or (times and time_s <= times[-1]):
            raise FlowvoError(f"timestamp {fields[0]} must be finite and later than the line before's", path,
                              number)
        times.append(time_s)
    if len(times) != count:
        raise FlowvoError(f"holds {len(times)} timestamps for the pose file's {count} poses", path)
    return np.array(times)


def _recorded_drive(summary: dict) -> dict | None:
    """run.json's ``drive`` when it holds every number, else None."""
    drive = summary.get("drive")
    if isinstance(drive, dict) and all(isinstance(drive.get(key), int | float) and not isinstance(drive[key], bool)
                                       and np.isfinite(drive[key]) for key in DRIVE_KEYS):
        return {key: float(drive[key]) for key in DRIVE_KEYS}
    return None


def _run_lengths(summary: dict, path: Path) -> tuple[float, ...]:
    """The sub-path lengths the run was evaluated on (run.json ``lengths_m``), else the devkit's."""
    lengths = summary.get("lengths_m", list(SEGMENT_LENGTHS_M))
    if not isinstance(lengths, list) or not lengths or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and 1.0 <= v <= 1e5 for v in lengths):
        raise FlowvoError("'lengths_m' must be a list of sub-path lengths in [1, 1e5] m", path)
    return tuple(sorted({float(v) for v in lengths}))


def _is_seconds(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and 0 <= value < float("inf")


def _read_record(path: Path, keys: tuple[str, ...]) -> dict:
    """A JSON object written by ``flowvo run``, checked to hold ``keys``; errors name the file."""
    if not path.is_file():
        raise FlowvoError(f"not a flowvo run folder (no {path.name})", path.parent)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise FlowvoError(f"not valid JSON ({getattr(error, 'msg', 'not UTF-8 text')})", path,
                          getattr(error, "lineno", None)) from None
    missing = [key for key in keys if not isinstance(data, dict) or key not in data]
    if missing:
        raise FlowvoError(f"lacks {', '.join(missing)}: not written by flowvo run, or damaged", path)
    return data
