"""The camera of a drive, from what the user gave (a calibration file, ``--fx ...``, ``--dist``,
``--camera-height``, ``--camera-pitch``, ``--camera-roll``, ``--readout-ms``) and what the drive itself says (KITTI
calib.txt, a ROS CameraInfo and /tf_static).

Precedence: intrinsics from ``--calib`` or ``--fx --fy --cx --cy`` replace the drive's (a KITTI calib.txt
too); distortion from
``--dist`` replaces the calibration file's, which replaces the drive's; the camera height from
``--camera-height``, else the calibration file's, else the drive's, else KITTI's 1.65 m (assumed, said so);
the pitch and the roll likewise from ``--camera-pitch`` and ``--camera-roll``, the calibration file's, the drive's,
else 0 (mounted level); a rolling shutter's readout time from ``--readout-ms``, the calibration file's, the drive's,
else 0 (a global shutter).

A calibration file that states its image size (OpenCV and ROS YAML ``image_width``/``image_height``, Kalibr
``resolution``) is checked against the frames: another size of the same aspect ratio (within a pixel) has
its intrinsics scaled to the frames (recorded as the camera's ``scaled_from_hw``); another aspect ratio is
refused. Lens distortion is checked to be undone over the frames (:func:`flowvo.camera.check_distortion`).
"""

from __future__ import annotations

from dataclasses import dataclass

from flowvo.camera import (
    Camera,
    CameraIntrinsics,
    LensDistortion,
    check_camera_height,
    check_camera_pitch,
    check_camera_roll,
    check_distortion,
    check_intrinsics,
    check_readout,
)
from flowvo.errors import FlowvoError


@dataclass(frozen=True)
class GivenCamera:
    """What the user said about the camera; every part optional. ``source``: "calib" or "flags" (for the
    intrinsics), ``where``: the file or flags to name in errors, ``image_size_hw``: (height, width) of the
    images the calibration file was made at, when it says; ``distortion_where``: where ``distortion`` came
    from (``--dist`` or the file); ``readout_ms``: a rolling shutter's readout time (milliseconds)."""

    intrinsics: CameraIntrinsics | None = None
    distortion: LensDistortion | None = None
    height_m: float | None = None
    source: str | None = None
    where: str = "camera flags"
    pitch_deg: float | None = None
    image_size_hw: tuple[int, int] | None = None
    distortion_where: str | None = None
    roll_deg: float | None = None
    readout_ms: float | None = None


def given_camera(calib: str | None, fx: float | None, fy: float | None, cx: float | None, cy: float | None,
                 distortion: tuple[float, ...] | None = None, distortion_model: str | None = None,
                 camera_height_m: float | None = None, camera_pitch_deg: float | None = None,
                 camera_roll_deg: float | None = None, readout_ms: float | None = None) -> GivenCamera:
    """Parse the camera flags (one-line errors for partial or conflicting ones)."""
    numbers = {"--fx": fx, "--fy": fy, "--cx": cx, "--cy": cy}
    given = [name for name, value in numbers.items() if value is not None]
    if calib is not None and given:
        raise FlowvoError(f"give either --calib or {', '.join(given)}, not both")
    intrinsics, file_distortion, file_height, file_pitch, source, where = None, None, None, None, None, "camera flags"
    file_roll, file_readout = None, None
    size_hw = None
    if calib is not None:
        from flowvo.calibration.files import read_camera_file

        camera_file = read_camera_file(calib)
        intrinsics, source, where, size_hw = camera_file.intrinsics, "calib", calib, camera_file.image_size_hw
        file_distortion, file_height, file_pitch = camera_file.distortion, camera_file.height_m, camera_file.pitch_deg
        file_roll, file_readout = camera_file.roll_deg, camera_file.readout_ms
    elif given:
        missing = [name for name in numbers if name not in given]
        if missing:
            raise FlowvoError(f"intrinsics need all of --fx --fy --cx --cy; missing {' '.join(missing)}")
        intrinsics, source, where = CameraIntrinsics(float(fx), float(fy), float(cx), float(cy)), "flags", \
            "--fx/--fy/--cx/--cy"  # type: ignore[arg-type]
    if distortion_model is not None and distortion is None:
        raise FlowvoError("--distortion-model needs --dist K1 K2 ...")
    distortion_where = None if file_distortion is None else where
    if distortion is not None:
        try:
            file_distortion = LensDistortion(distortion_model or "plumb_bob", tuple(distortion))
        except FlowvoError as error:
            raise FlowvoError(error.message, "--dist") from None
        distortion_where = "--dist"
    if camera_height_m is not None:
        file_height = check_camera_height(camera_height_m, "--camera-height")
    if camera_pitch_deg is not None:
        file_pitch = check_camera_pitch(camera_pitch_deg, "--camera-pitch")
    if camera_roll_deg is not None:
        file_roll = check_camera_roll(camera_roll_deg, "--camera-roll")
    if readout_ms is not None:
        file_readout = check_readout(readout_ms, "--readout-ms")
    return GivenCamera(intrinsics, file_distortion, file_height, source, where, file_pitch, size_hw, distortion_where,
                       file_roll, file_readout)


def drive_camera(given: GivenCamera, drive: Camera | None, image_size_hw: tuple[int, int], where: str,
                 drive_height_m: float | None = None, drive_pitch_deg: float | None = None,
                 drive_roll_deg: float | None = None) -> Camera:
    """The camera a drive runs with: ``given`` over the ``drive``'s own (and the height, pitch and roll the drive
    states, ``drive_height_m``, ``drive_pitch_deg`` and ``drive_roll_deg``; the readout time its camera states),
    checked against its frames."""
    if given.intrinsics is None and drive is None:
        raise FlowvoError("no camera intrinsics: give --calib FILE or --fx --fy --cx --cy (pixels of the frames)",
                          where)
    intrinsics = given.intrinsics or drive.intrinsics  # type: ignore[union-attr]
    distortion = given.distortion or (drive.distortion if drive and given.intrinsics is None else None)
    height_m = next((h for h in (given.height_m, drive.height_m if drive else None, drive_height_m) if h is not None),
                    None)
    pitch_deg = next((p for p in (given.pitch_deg, drive_pitch_deg, drive.pitch_deg if drive else None)
                      if p is not None), 0.0)
    roll_deg = next((r for r in (given.roll_deg, drive_roll_deg, drive.roll_deg if drive else None)
                     if r is not None), 0.0)
    readout_ms = next((r for r in (given.readout_ms, drive.readout_ms if drive else None) if r is not None), 0.0)
    source = given.source or drive.source  # type: ignore[union-attr]
    scaled_from_hw = None
    if given.intrinsics is not None and given.image_size_hw not in (None, tuple(image_size_hw)):
        intrinsics, scaled_from_hw = scaled_to_frames(intrinsics, given.image_size_hw, image_size_hw, given.where)
    camera = Camera(intrinsics, distortion or LensDistortion(), height_m, source, pitch_deg, scaled_from_hw, roll_deg,
                    readout_ms)
    check_intrinsics(camera.intrinsics, image_size_hw, given.where if given.intrinsics else where)
    check_camera_pitch(pitch_deg, where)  # a drive's own (a bag's /tf_static) may be beyond what flowvo handles
    check_camera_roll(roll_deg, where)
    check_distortion(camera.intrinsics, camera.distortion, image_size_hw,
                     given.distortion_where if given.distortion is not None else where)
    return camera


def scaled_to_frames(intrinsics: CameraIntrinsics, calibrated_hw: tuple[int, int], frames_hw: tuple[int, int],
                     where: str) -> tuple[CameraIntrinsics, tuple[int, int]]:
    """Intrinsics calibrated on images of ``calibrated_hw`` (height, width) scaled to frames of ``frames_hw``
    of the same aspect ratio (within a pixel: 1281x721 is 1280x720's), with the calibration's size; a one-line
    error naming the calibration ``where`` and both sizes for another aspect ratio (a cropped or another
    sensor mode, which no scaling makes right)."""
    (ch, cw), (fh, fw) = calibrated_hw, frames_hw
    if abs(cw * fh / ch - fw) > 1.0 and abs(ch * fw / cw - fh) > 1.0:
        raise FlowvoError(f"calibrated on {cw}x{ch} images, the frames are {fw}x{fh}: another aspect ratio (a crop "
                          "or another sensor mode), so the intrinsics do not apply; calibrate the camera at the "
                          "frames' size", where)
    return intrinsics.scaled(fw / cw, fh / ch), (ch, cw)
