"""One drive of a batch: where its frames are, its output name, and the ``flowvo run`` options it runs with.

A batch has defaults (the drive options of ``flowvo run``); a manifest line may override some of them for
its drive (:data:`SETTING_FIELDS`). :func:`drive_run_options` makes the exact options ``flowvo run`` gets.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flowvo.drive.options import RunOptions
from flowvo.errors import FlowvoError
from flowvo.io.atomic import strict_json_dumps

DRIVE_KINDS = ("kitti", "video", "bag")
INTRINSICS_FIELDS = ("calib", "fx", "fy", "cx", "cy")
# RunOptions fields a manifest line may set for its drive (its columns, besides path, kind, sequence, name).
SETTING_FIELDS = (*INTRINSICS_FIELDS, "camera_height_m", "method", "topic", "camera_info_topic")
# RunOptions fields that do not shape a drive's result: where it is, where its outputs go, how it is scheduled.
_NOT_SHAPING_FIELDS = ("out", "force", "data", "video", "bag", "overlap_stages")


@dataclass(frozen=True)
class Drive:
    """One drive of a batch.

    ``name``: its output folder under ``OUT/drives`` (a plain name, unique in the batch).
    ``kind``: "kitti" (``path`` a dataset root, with ``sequence``), "video" (``path`` a video file) or
    "bag" (``path`` a ROS 1 bag, a ROS 2 bag folder or an MCAP file).
    ``settings``: RunOptions fields of :data:`SETTING_FIELDS` that override the batch defaults for it.
    """

    name: str
    kind: str
    path: str
    sequence: str | None = None
    settings: dict[str, Any] = field(default_factory=dict)


def drive_folder(out: str | Path, drive: Drive) -> Path:
    """Where the outputs of ``drive`` go: ``OUT/drives/NAME`` (exactly what ``flowvo run`` writes)."""
    return Path(out) / "drives" / drive.name


def drive_run_options(drive: Drive, defaults: RunOptions, out: str | Path) -> RunOptions:
    """The options ``flowvo run`` gets for ``drive``: ``defaults`` with its source, its output folder and
    its settings, its stages in one thread (a batch runs one drive per core). Intrinsics given for the
    drive (a manifest's calib file or four numbers) replace the defaults' whole; either replaces the drive's
    own, a KITTI sequence's calib.txt too, as in ``flowvo run``.
    """
    unknown = sorted(set(drive.settings) - set(SETTING_FIELDS))
    if unknown:
        raise FlowvoError(f"drive {drive.name}: unknown settings {', '.join(unknown)}")
    source = {"kitti": {"data": drive.path, "sequence": drive.sequence}, "video": {"video": drive.path},
              "bag": {"bag": drive.path}}
    if drive.kind not in source:
        raise FlowvoError(f"drive {drive.name}: kind {drive.kind!r} is not one of {', '.join(DRIVE_KINDS)}")
    intrinsics: dict[str, Any] = {}
    if any(drive.settings.get(name) is not None for name in INTRINSICS_FIELDS):
        intrinsics = dict.fromkeys(INTRINSICS_FIELDS)
    fields: dict[str, Any] = {"out": str(drive_folder(out, drive)), "force": False, "overlap_stages": False,
                              "data": None, "sequence": None, "video": None, "bag": None}
    fields.update(source[drive.kind])
    fields.update(intrinsics)
    fields.update({k: v for k, v in drive.settings.items() if v is not None})
    return dataclasses.replace(defaults, **fields)


def processing_settings(options: RunOptions) -> dict[str, Any]:
    """The options that shape a drive's result, as JSON values (recorded in the summary, compared on resume):
    every field except where the drive is, where its outputs go and how its stages are scheduled."""
    settings = {k: v for k, v in dataclasses.asdict(options).items() if k not in _NOT_SHAPING_FIELDS}
    return json.loads(strict_json_dumps(settings))


def check_drive_options(drive: Drive, options: RunOptions, intrinsics_checked: dict[tuple, None]) -> None:
    """Refuse, before anything runs, a drive its options cannot run: a bag without an image topic, an
    unreadable calibration file or invalid camera numbers, for every kind of drive (a video without
    intrinsics has its focal length estimated when it runs; what needs the frames, such as a calibration's
    image size or a lens model over them, is checked when the drive runs). ``intrinsics_checked``
    remembers the camera options already checked (a fleet shares a few calibration files)."""
    from flowvo.camera_options import given_camera

    if drive.kind == "bag" and options.topic is None:
        raise FlowvoError(f"drive {drive.name} is a bag: give --topic IMAGE_TOPIC (or a 'topic' manifest column)")
    given = (options.calib, options.fx, options.fy, options.cx, options.cy, options.distortion,
             options.distortion_model, options.camera_height_m, options.camera_pitch_deg, options.camera_roll_deg,
             options.readout_ms)
    if given not in intrinsics_checked:
        try:
            given_camera(*given)
        except FlowvoError as error:
            raise FlowvoError(f"drive {drive.name}: {error}") from None
        intrinsics_checked[given] = None
