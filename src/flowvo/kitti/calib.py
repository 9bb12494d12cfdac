"""KITTI ``calib.txt``: projection matrices P0..P3 (3x4, pixels) and the optional velodyne ``Tr``."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flowvo.errors import FlowvoError

REQUIRED_KEYS = ("P0",)


@dataclass(frozen=True)
class Calibration:
    """Projection matrices by name ("P0".."P3", optionally "Tr"), each (3, 4)."""

    matrices: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def K0(self) -> np.ndarray:
        """Intrinsics (3, 3) of the left grey camera (image_0), pixels."""
        return self.matrices["P0"][:, :3]

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
    with open(path, encoding="utf-8", errors="replace") as handle:  # binary bytes then fail as text, per line
        for line_number, line in enumerate(handle, start=1):
            if not line.strip():
                continue
            name, sep, rest = line.partition(":")
            if not sep:
                raise FlowvoError("expected 'NAME: 12 numbers'", path, line_number)
            try:
                values = [float(v) for v in rest.split()]
            except ValueError:
                raise FlowvoError(f"{name.strip()}: expected 12 numbers, found text", path, line_number) from None
            if len(values) != 12:
                raise FlowvoError(f"{name.strip()}: expected 12 numbers, found {len(values)}", path, line_number)
            matrices[name.strip()] = np.reshape(values, (3, 4))
    missing = [key for key in REQUIRED_KEYS if key not in matrices]
    if missing:
        raise FlowvoError(f"missing {', '.join(missing)}", path)
    return Calibration(matrices)


def format_calibration(calibration: Calibration) -> str:
    """calib.txt text in KITTI's layout."""
    lines = []
    for name, matrix in calibration.matrices.items():
        lines.append(f"{name}: " + " ".join(f"{v:.12e}" for v in matrix.reshape(-1)))
    return "\n".join(lines) + "\n"
