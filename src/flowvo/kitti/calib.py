"""KITTI ``calib.txt``: projection matrices P0..P3 (3x4, pixels) and the optional velodyne ``Tr``.

flowvo also reads five optional lines that describe the camera beyond KITTI's: ``distortion_model: NAME``
(default plumb_bob, or rational_polynomial for 8 numbers), ``distortion: k1 k2 p1 p2 [k3 ...]``,
``camera_height_m: H`` (metres above the road), ``camera_pitch_deg: P`` (degrees below the road's plane, down
positive), ``camera_roll_deg: R`` (degrees about the optical axis after the pitch, right side down positive) and
``readout_ms: T`` (a rolling shutter's time from the first row's exposure to the last's, milliseconds), and writes them
for cameras that have them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flowvo.camera import (
    NO_DISTORTION,
    LensDistortion,
    check_camera_height,
    check_camera_pitch,
    check_camera_roll,
    check_readout,
)
from flowvo.errors import FlowvoError
from flowvo.io.text_numbers import parse_float

REQUIRED_KEYS = ("P0",)
CAMERA_KEYS = ("distortion_model", "distortion", "camera_height_m", "camera_pitch_deg", "camera_roll_deg", "readout_ms")


@dataclass(frozen=True)
class Calibration:
    """Projection matrices by name ("P0".."P3", optionally "Tr"), each (3, 4)."""

    matrices: dict[str, np.ndarray] = field(default_factory=dict)
    distortion: LensDistortion = NO_DISTORTION
    camera_height_m: float | None = None
    camera_pitch_deg: float | None = None
    camera_roll_deg: float | None = None
    readout_ms: float | None = None

    @property
    def K0(self) -> np.ndarray:
        """Intrinsics (3, 3) of the left grey camera (image_0), pixels."""
        return self.matrices["P0"][:, :3].copy()  # a view would reach OpenCV strided

    @property
    def baseline_m(self) -> float:
        """Stereo baseline between cameras 0 and 1 in metres, from ``P1[0, 3] = -fx * b``."""
        if "P1" not in self.matrices:
            raise FlowvoError("calibration has no P1 (monocular): no stereo baseline")
        return float(-self.matrices["P1"][0, 3] / self.matrices["P1"][0, 0])


def read_calibration(path: str | Path) -> Calibration:
    """Parse ``calib.txt``; every line is ``NAME: 12 floats``; only P0 (the left grey camera) is required,
    as monocular tools write it."""
    path = Path(path)
    if not path.is_file():
        raise FlowvoError("calibration file not found", path)
    matrices: dict[str, np.ndarray] = {}
    extras: dict[str, tuple[int, str]] = {}
    with open(path, encoding="utf-8-sig", errors="replace") as handle:  # binary bytes fail as text, per line; -sig:
        # a byte-order mark is no part of the first line
        for line_number, line in enumerate(handle, start=1):
            if not line.strip():
                continue
            name, sep, rest = line.partition(":")
            if not sep:
                raise FlowvoError("expected 'NAME: 12 numbers'", path, line_number)
            if name.strip() in CAMERA_KEYS:
                extras[name.strip()] = (line_number, rest.strip())
                continue
            try:
                values = [parse_float(v) for v in rest.split()]
            except ValueError:
                raise FlowvoError(f"{name.strip()}: expected 12 numbers, found text", path, line_number) from None
            if len(values) != 12:
                raise FlowvoError(f"{name.strip()}: expected 12 numbers, found {len(values)}", path, line_number)
            matrices[name.strip()] = np.reshape(values, (3, 4))
            if name.strip() == "P0":
                _check_projection(matrices["P0"], path, line_number)
    missing = [key for key in REQUIRED_KEYS if key not in matrices]
    if missing:
        raise FlowvoError(f"missing {', '.join(missing)}", path)
    return Calibration(matrices, *_camera_lines(extras, path))


def _check_projection(P: np.ndarray, path: Path, line_number: int) -> None:
    """Refuse a P0 that images nothing: non-finite numbers, or focal lengths that are not positive (an
    all-zero matrix is a placeholder, not a camera). Ranges against the frames are checked later, with
    every other source's camera (:func:`flowvo.camera_options.check_intrinsics`)."""
    if not np.all(np.isfinite(P)):
        raise FlowvoError("P0: every number must be finite (found NaN or infinity)", path, line_number)
    if not (P[0, 0] > 0 and P[1, 1] > 0):
        raise FlowvoError(f"P0: focal lengths fx={P[0, 0]:g}, fy={P[1, 1]:g} px must be positive (entries 1 and 6 "
                          "of the 12)", path, line_number)


def _camera_lines(extras: dict[str, tuple[int, str]], path: Path
                  ) -> tuple[LensDistortion, float | None, float | None, float | None, float | None]:
    """The lens distortion, camera height, pitch, roll and readout time of the optional camera lines."""
    numbers: dict[str, list[float]] = {}
    for key in ("distortion", "camera_height_m", "camera_pitch_deg", "camera_roll_deg", "readout_ms"):
        if key in extras:
            line_number, text = extras[key]
            try:
                numbers[key] = [parse_float(v) for v in text.split()]
            except ValueError:
                raise FlowvoError(f"{key}: expected numbers, found text", path, line_number) from None
    distortion = NO_DISTORTION
    if "distortion" in numbers:
        coefficients = numbers["distortion"]
        default_model = "rational_polynomial" if len(coefficients) == 8 else "plumb_bob"
        line_number, model = extras.get("distortion_model", (extras["distortion"][0], default_model))
        try:
            distortion = LensDistortion(model or default_model, tuple(coefficients))
        except FlowvoError as error:
            raise FlowvoError(str(error), path, line_number) from None
    height_m, pitch_deg, roll_deg, readout_ms = (
        _single_number(numbers, extras, key, unit, check, path) for key, unit, check in
        (("camera_height_m", "metres", check_camera_height), ("camera_pitch_deg", "degrees", check_camera_pitch),
         ("camera_roll_deg", "degrees", check_camera_roll), ("readout_ms", "milliseconds", check_readout)))
    return distortion, height_m, pitch_deg, roll_deg, readout_ms


def _single_number(numbers: dict[str, list[float]], extras: dict[str, tuple[int, str]], key: str, unit: str,
                   check: Callable[[float, str], float], path: Path) -> float | None:
    """The one number of the optional line ``key`` (in ``unit``), checked by ``check``; None without the line."""
    if key not in numbers:
        return None
    line_number, _ = extras[key]
    if len(numbers[key]) != 1:
        raise FlowvoError(f"{key}: expected one number ({unit})", path, line_number)
    return check(numbers[key][0], f"{path}:{line_number}")


def format_calibration(calibration: Calibration) -> str:
    """calib.txt text in KITTI's layout."""
    lines = []
    for name, matrix in calibration.matrices.items():
        lines.append(f"{name}: " + " ".join(f"{v:.12e}" for v in matrix.reshape(-1)))
    if not calibration.distortion.is_none:
        lines.append(f"distortion_model: {calibration.distortion.model}")
        lines.append("distortion: " + " ".join(f"{v:.12e}" for v in calibration.distortion.coefficients))
    if calibration.camera_height_m is not None:
        lines.append(f"camera_height_m: {calibration.camera_height_m:.6f}")
    if calibration.camera_pitch_deg is not None:
        lines.append(f"camera_pitch_deg: {calibration.camera_pitch_deg:.6f}")
    if calibration.camera_roll_deg is not None:
        lines.append(f"camera_roll_deg: {calibration.camera_roll_deg:.6f}")
    if calibration.readout_ms is not None:
        lines.append(f"readout_ms: {calibration.readout_ms:.6f}")
    return "\n".join(lines) + "\n"
