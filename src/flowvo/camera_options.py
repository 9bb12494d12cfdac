"""The camera of a drive, from what the user gave (a calibration file, ``--fx ...``, ``--dist``,
``--camera-height``, ``--camera-pitch``) and what the drive itself says (KITTI calib.txt, a ROS CameraInfo and
/tf_static).

Precedence: intrinsics from ``--calib`` or ``--fx --fy --cx --cy`` replace the drive's; distortion from
``--dist`` replaces the calibration file's, which replaces the drive's; the camera height from
``--camera-height``, else the calibration file's, else the drive's, else KITTI's 1.65 m (assumed, said so);
the pitch likewise from ``--camera-pitch``, the calibration file's, the drive's, else 0 (mounted level).
"""

from __future__ import annotations

from dataclasses import dataclass

from flowvo.camera import (
    Camera,
    CameraIntrinsics,
    LensDistortion,
    check_camera_height,
    check_camera_pitch,
    check_intrinsics,
)
from flowvo.errors import FlowvoError


@dataclass(frozen=True)
class GivenCamera:
    """What the user said about the camera; every part optional. ``source``: "calib" or "flags" (for the
    intrinsics), ``where``: the file or flags to name in errors."""

    intrinsics: CameraIntrinsics | None = None
    distortion: LensDistortion | None = None
    height_m: float | None = None
    source: str | None = None
    where: str = "camera flags"
    pitch_deg: float | None = None


def given_camera(calib: str | None, fx: float | None, fy: float | None, cx: float | None, cy: float | None,
                 distortion: tuple[float, ...] | None = None, distortion_model: str | None = None,
                 camera_height_m: float | None = None, camera_pitch_deg: float | None = None) -> GivenCamera:
    """Parse the camera flags (one-line errors for partial or conflicting ones)."""
    numbers = {"--fx": fx, "--fy": fy, "--cx": cx, "--cy": cy}
    given = [name for name, value in numbers.items() if value is not None]
    if calib is not None and given:
        raise FlowvoError(f"give either --calib or {', '.join(given)}, not both")
    intrinsics, file_distortion, file_height, file_pitch, source, where = None, None, None, None, None, "camera flags"
    if calib is not None:
        from flowvo.calibration.files import read_camera_file

        camera_file = read_camera_file(calib)
        intrinsics, source, where = camera_file.intrinsics, "calib", calib
        file_distortion, file_height, file_pitch = camera_file.distortion, camera_file.height_m, camera_file.pitch_deg
    elif given:
        missing = [name for name in numbers if name not in given]
        if missing:
            raise FlowvoError(f"intrinsics need all of --fx --fy --cx --cy; missing {' '.join(missing)}")
        intrinsics, source, where = CameraIntrinsics(float(fx), float(fy), float(cx), float(cy)), "flags", \
            "--fx/--fy/--cx/--cy"  # type: ignore[arg-type]
    if distortion_model is not None and distortion is None:
        raise FlowvoError("--distortion-model needs --dist K1 K2 ...")
    if distortion is not None:
        file_distortion = LensDistortion(distortion_model or "plumb_bob", tuple(distortion))
    if camera_height_m is not None:
        file_height = check_camera_height(camera_height_m, "--camera-height")
    if camera_pitch_deg is not None:
        file_pitch = check_camera_pitch(camera_pitch_deg, "--camera-pitch")
    return GivenCamera(intrinsics, file_distortion, file_height, source, where, file_pitch)


def drive_camera(given: GivenCamera, drive: Camera | None, image_size_hw: tuple[int, int], where: str,
                 drive_height_m: float | None = None, drive_pitch_deg: float | None = None) -> Camera:
    """The camera a drive runs with: ``given`` over the ``drive``'s own (and the height and pitch the drive
    states, ``drive_height_m`` and ``drive_pitch_deg``), checked against its frames."""
    if given.intrinsics is None and drive is None:
        raise FlowvoError("no camera intrinsics: give --calib FILE or --fx --fy --cx --cy (pixels of the frames)",
                          where)
    intrinsics = given.intrinsics or drive.intrinsics  # type: ignore[union-attr]
    distortion = given.distortion or (drive.distortion if drive and given.intrinsics is None else None)
    height_m = next((h for h in (given.height_m, drive.height_m if drive else None, drive_height_m) if h is not None),
                    None)
    pitch_deg = next((p for p in (given.pitch_deg, drive_pitch_deg, drive.pitch_deg if drive else None)
                      if p is not None), 0.0)
    source = given.source or drive.source  # type: ignore[union-attr]
    camera = Camera(intrinsics, distortion or LensDistortion(), height_m, source, pitch_deg)
    check_intrinsics(camera.intrinsics, image_size_hw, given.where if given.intrinsics else where)
    check_camera_pitch(pitch_deg, where)  # a drive's own (a bag's /tf_static) may be beyond what flowvo handles
    return camera
