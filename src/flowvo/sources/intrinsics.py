"""Camera intrinsics from the command line: a KITTI ``calib.txt`` (its P0) or explicit fx, fy, cx, cy."""

from __future__ import annotations

import math

from flowvo.camera import CameraIntrinsics
from flowvo.errors import FlowvoError
from flowvo.kitti.calib import read_calibration


def intrinsics_from_options(calib: str | None, fx: float | None, fy: float | None, cx: float | None,
                            cy: float | None, image_size_hw: tuple[int, int] | None = None
                            ) -> CameraIntrinsics | None:
    """Intrinsics from ``calib`` (P0 of a KITTI calib.txt) or all four numbers; None when neither is given.

    Raises a one-line error when only some numbers are given, when both forms are given, or when a
    value is not finite and positive (the principal point must lie inside the image when its size is known).
    """
    numbers = {"--fx": fx, "--fy": fy, "--cx": cx, "--cy": cy}
    given = [name for name, value in numbers.items() if value is not None]
    if calib is not None and given:
        raise FlowvoError(f"give either --calib or {', '.join(given)}, not both")
    if calib is not None:
        intrinsics = CameraIntrinsics.from_matrix(read_calibration(calib).K0)
    elif given:
        missing = [name for name in numbers if name not in given]
        if missing:
            raise FlowvoError(f"intrinsics need all of --fx --fy --cx --cy; missing {' '.join(missing)}")
        intrinsics = CameraIntrinsics(float(fx), float(fy), float(cx), float(cy))  # type: ignore[arg-type]
    else:
        return None
    check_intrinsics(intrinsics, image_size_hw, calib or "--fx/--fy/--cx/--cy")
    return intrinsics


def check_intrinsics(intrinsics: CameraIntrinsics, image_size_hw: tuple[int, int] | None, where: str) -> None:
    """Refuse non-finite or non-positive focal lengths and a principal point outside the image."""
    values = (intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy)
    if not all(math.isfinite(v) for v in values) or intrinsics.fx <= 0 or intrinsics.fy <= 0:
        raise FlowvoError(f"intrinsics must be finite with positive focal lengths, got fx={intrinsics.fx} "
                          f"fy={intrinsics.fy} cx={intrinsics.cx} cy={intrinsics.cy}", where)
    if image_size_hw is not None:
        h, w = image_size_hw
        if not (0 <= intrinsics.cx < w and 0 <= intrinsics.cy < h):
            raise FlowvoError(f"principal point ({intrinsics.cx}, {intrinsics.cy}) lies outside the {w}x{h} image",
                              where)
