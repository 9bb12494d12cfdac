"""Batch manifests: one drive (or one folder of drives) per line, with per-drive settings.

Formats: CSV with a header line (``.csv``) or JSON Lines, one object per line (``.jsonl``, ``.ndjson``).
Columns (only ``path`` is required; an empty cell or JSON null means "the batch default"):

- ``path``: a video file, a bag, a KITTI dataset root, a sequence folder or a folder holding drives;
  relative paths are relative to the manifest's folder;
- ``kind``: kitti, video or bag (default: from the path);
- ``sequence``: with a KITTI dataset root, that sequence only;
- ``name``: the drive's output name (default: from its path);
- ``calib`` (any calibration file ``--calib`` reads, relative to the manifest) or ``fx``, ``fy``, ``cx``,
  ``cy`` (pixels): the drive's intrinsics (for a KITTI sequence they replace its calib.txt's, as ``--calib``
  does);
- ``camera_height_m``: camera height above the road in metres;
- ``method``: one of ``flowvo run``'s methods;
- ``topic``, ``camera_info_topic``: a bag's image and CameraInfo topics.

Any other column, a path that does not exist, or a value that is not what its column expects (an
unreadable calibration file, partial intrinsics, a camera height beyond 10 m) is an error naming the
manifest, the line and the column.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flowvo.batch.spec import DRIVE_KINDS
from flowvo.errors import FlowvoError
from flowvo.io.outputs import validate_name
from flowvo.methods import METHODS

MANIFEST_SUFFIXES = (".csv", ".jsonl", ".ndjson")
_POSITIVE = ("fx", "fy", "camera_height_m")  # finite, > 0
_NON_NEGATIVE = ("cx", "cy")  # finite, >= 0
COLUMNS = ("path", "kind", "sequence", "name", "calib", *_POSITIVE, *_NON_NEGATIVE, "method", "topic",
           "camera_info_topic")


@dataclass(frozen=True)
class ManifestLine:
    """One line of a manifest: ``path`` (absolute), optional ``kind``, ``sequence`` and ``name``, and the
    RunOptions ``settings`` it gives its drives; ``where`` is "MANIFEST:LINE" for messages."""

    path: Path
    kind: str | None
    sequence: str | None
    name: str | None
    settings: dict[str, Any] = field(default_factory=dict)
    where: str = ""


def is_manifest(path: str | Path) -> bool:
    """True for a file whose suffix names a manifest format."""
    return Path(path).suffix.lower() in MANIFEST_SUFFIXES and Path(path).is_file()


def read_manifest(path: str | Path) -> list[ManifestLine]:
    """Every line of the manifest at ``path``, checked (see the module docstring)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise FlowvoError("manifest is not UTF-8 text", path) from None
    records = _csv_records(text, path) if path.suffix.lower() == ".csv" else _json_records(text, path)
    lines = [_line(record, path, number) for number, record in records]
    if not lines:
        raise FlowvoError("manifest lists no drives", path)
    return lines


def _csv_records(text: str, path: Path) -> list[tuple[int, dict[str, Any]]]:
    reader = csv.reader(text.splitlines())
    header = next(reader, None)
    if header is None:
        raise FlowvoError("manifest is empty (expected a header line naming the columns)", path)
    header = [column.strip() for column in header]
    _check_columns(header, path, 1)
    records = []
    for cells in reader:
        if not any(cell.strip() for cell in cells):
            continue
        if len(cells) > len(header):
            raise FlowvoError(f"{len(cells)} fields for the header's {len(header)} columns", path, reader.line_num)
        records.append((reader.line_num, dict(zip(header, cells, strict=False))))
    return records


def _json_records(text: str, path: Path) -> list[tuple[int, dict[str, Any]]]:
    records = []
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except json.JSONDecodeError as error:
            raise FlowvoError(f"not a JSON object: {error.msg}", path, number) from None
        if not isinstance(record, dict):
            raise FlowvoError("expected one JSON object per line", path, number)
        _check_columns(list(record), path, number)
        records.append((number, record))
    return records


def _check_columns(names: list[str], path: Path, line: int) -> None:
    unknown = [name for name in names if name not in COLUMNS]
    if unknown:
        raise FlowvoError(f"unknown column(s) {', '.join(map(repr, unknown))}; expected some of {', '.join(COLUMNS)}",
                          path, line)
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise FlowvoError(f"column(s) {', '.join(repeated)} given twice", path, line)
    if "path" not in names:
        raise FlowvoError("no 'path' column", path, line)


def _line(record: dict[str, Any], manifest: Path, number: int) -> ManifestLine:
    values = {name: _value(name, record.get(name), manifest, number) for name in COLUMNS}
    if values["path"] is None:
        raise FlowvoError("'path' is empty", manifest, number)
    drive_path = _existing(values["path"], manifest, number, "path")
    if values["calib"] is not None:
        values["calib"] = str(_existing(values["calib"], manifest, number, "calib"))
    if values["kind"] is not None and values["kind"] not in DRIVE_KINDS:
        raise FlowvoError(f"kind {values['kind']!r} is not one of {', '.join(DRIVE_KINDS)}", manifest, number)
    if values["method"] is not None and values["method"] not in METHODS:
        raise FlowvoError(f"method {values['method']!r} is not one of {', '.join(METHODS)}", manifest, number)
    if values["name"] is not None:
        try:
            validate_name(values["name"], "drive")
        except FlowvoError as error:
            raise FlowvoError(error.message, manifest, number) from None
    _check_camera(values, manifest, number)
    settings = {k: v for k, v in values.items() if k not in ("path", "kind", "sequence", "name") and v is not None}
    return ManifestLine(drive_path, values["kind"], values["sequence"], values["name"], settings,
                        f"{manifest}:{number}")


def _check_camera(values: dict[str, Any], manifest: Path, number: int) -> None:
    """The line's camera columns as ``flowvo run`` would take them: a readable calibration file or all four
    intrinsics (not both), focal lengths in range, a plausible camera height; errors name the column."""
    from flowvo.calibration.files import read_camera_file
    from flowvo.camera import CameraIntrinsics, check_camera_height, check_intrinsics

    numbers = [name for name in ("fx", "fy", "cx", "cy") if values[name] is not None]
    try:
        if values["calib"] is not None and numbers:
            raise FlowvoError(f"calib, {', '.join(numbers)}: give either a calibration file or fx, fy, cx, cy")
        if numbers and len(numbers) < 4:
            missing = [name for name in ("fx", "fy", "cx", "cy") if name not in numbers]
            raise FlowvoError(f"{', '.join(numbers)}: fx, fy, cx, cy go together; missing {', '.join(missing)}")
        if numbers:
            try:
                check_intrinsics(CameraIntrinsics(*(values[name] for name in ("fx", "fy", "cx", "cy"))), None, None)
            except FlowvoError as error:
                raise FlowvoError(f"fx, fy, cx, cy: {error.message}") from None
        if values["calib"] is not None:
            try:
                read_camera_file(values["calib"])
            except FlowvoError as error:
                raise FlowvoError(f"calib: {error}") from None
        if values["camera_height_m"] is not None:
            try:
                check_camera_height(values["camera_height_m"])
            except FlowvoError as error:
                raise FlowvoError(f"camera_height_m: {error.message}") from None
    except FlowvoError as error:
        raise FlowvoError(error.message, manifest, number) from None


def _value(name: str, raw: Any, manifest: Path, number: int) -> Any:
    """One cell as its column's type: text stripped, numbers finite and in range; None when empty."""
    if raw is None or (isinstance(raw, str) and not raw.strip()):
        return None
    if name in _POSITIVE or name in _NON_NEGATIVE:
        try:
            if isinstance(raw, bool) or not isinstance(raw, int | float | str):
                raise ValueError
            number_value = float(raw)
        except ValueError:
            raise FlowvoError(f"{name} must be a number, got {raw!r}", manifest, number) from None
        low_ok = number_value > 0 if name in _POSITIVE else number_value >= 0
        if not math.isfinite(number_value) or not low_ok:
            bound = "> 0" if name in _POSITIVE else ">= 0"
            raise FlowvoError(f"{name} must be finite and {bound}, got {raw!r}", manifest, number)
        return number_value
    if not isinstance(raw, str):
        raise FlowvoError(f"{name} must be text, got {raw!r}", manifest, number)
    return raw.strip()


def _existing(text: str, manifest: Path, number: int, column: str) -> Path:
    path = Path(text).expanduser()
    path = path if path.is_absolute() else manifest.parent / path
    if not path.exists():
        raise FlowvoError(f"{column} {text!r} not found ({path})", manifest, number)
    return path.absolute()
