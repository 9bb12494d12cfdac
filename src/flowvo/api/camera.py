"""``flowvo.Camera``: the camera of a drive, as a user gives it in Python.

Pixels are those of the frames pushed or read (x right, y down); the camera frame is x right, y down, z forward;
heights in metres, pitch and roll in degrees (down and right side down positive). It is a
:class:`flowvo.camera.Camera` (the internal camera every method takes) with a constructor of plain numbers and
:meth:`Camera.from_file` for every calibration file ``--calib`` reads (:mod:`flowvo.calibration.files`); a run applies
it as the command line applies ``--calib`` or ``--fx --fy --cx --cy`` (:mod:`flowvo.camera_options`), so the same
camera gives the same poses either way.
"""

from __future__ import annotations

from pathlib import Path

from flowvo.camera import Camera as _Camera
from flowvo.camera import (
    CameraIntrinsics,
    LensDistortion,
    check_camera_height,
    check_camera_pitch,
    check_camera_roll,
    check_intrinsics,
    check_readout,
)
from flowvo.camera_options import GivenCamera, given_camera


class Camera(_Camera):
    """A pinhole camera: focal lengths ``fx``, ``fy`` and principal point ``cx``, ``cy`` in pixels of the frames;
    lens ``distortion`` coefficients in ``model``'s order (``plumb_bob``: k1 k2 p1 p2 [k3];
    ``rational_polynomial``: 8; ``equidistant``: k1..k4; none by default); ``height_m``, the camera's height above
    the road in metres (None: KITTI's 1.65 m is assumed); ``pitch_deg``, how far it looks below the road's plane
    (degrees, down positive; 0: mounted level); ``roll_deg``, how far it is then rolled about its optical axis
    (degrees, right side down positive; 0: level); ``readout_ms``, a rolling shutter's time from exposing the first
    row to the last (milliseconds; 0: a global shutter).

    >>> camera = Camera(718.856, 718.856, 607.1928, 185.2157, height_m=1.65)
    >>> camera.fx, camera.camera_height_m
    (718.856, 1.65)
    """

    def __init__(self, fx: float, fy: float, cx: float, cy: float, *, distortion: tuple[float, ...] = (),
                 model: str = "plumb_bob", height_m: float | None = None, pitch_deg: float = 0.0,
                 roll_deg: float = 0.0, readout_ms: float = 0.0) -> None:
        intrinsics = CameraIntrinsics(float(fx), float(fy), float(cx), float(cy))
        check_intrinsics(intrinsics, None, "flowvo.Camera")
        super().__init__(intrinsics, LensDistortion(model, tuple(distortion)),
                         None if height_m is None else check_camera_height(height_m, "flowvo.Camera height_m"),
                         "flags", check_camera_pitch(pitch_deg, "flowvo.Camera pitch_deg"),
                         roll_deg=check_camera_roll(roll_deg, "flowvo.Camera roll_deg"),
                         readout_ms=check_readout(readout_ms, "flowvo.Camera readout_ms"))
        object.__setattr__(self, "file", None)

    @classmethod
    def from_file(cls, path: str | Path, *, height_m: float | None = None, pitch_deg: float | None = None,
                  roll_deg: float | None = None, readout_ms: float | None = None) -> Camera:
        """The camera of a calibration file: KITTI ``calib.txt`` (P0), OpenCV FileStorage YAML/XML, ROS
        ``camera_calibration`` YAML (what ``flowvo calibrate`` writes) or a Kalibr camchain. ``height_m``,
        ``pitch_deg``, ``roll_deg`` and ``readout_ms`` override the file's. A file made at another image size of the
        same aspect ratio is scaled to the frames when they arrive, as ``--calib`` does."""
        given = given_camera(str(path), None, None, None, None, camera_height_m=height_m,
                             camera_pitch_deg=pitch_deg, camera_roll_deg=roll_deg, readout_ms=readout_ms)
        i = given.intrinsics
        camera = cls(i.fx, i.fy, i.cx, i.cy, distortion=given.distortion.coefficients if given.distortion else (),
                     model=given.distortion.model if given.distortion and not given.distortion.is_none
                     else "plumb_bob", height_m=given.height_m, pitch_deg=given.pitch_deg or 0.0,
                     roll_deg=given.roll_deg or 0.0, readout_ms=given.readout_ms or 0.0)
        object.__setattr__(camera, "source", "calib")
        object.__setattr__(camera, "file", (str(path), height_m, pitch_deg, roll_deg, readout_ms))
        return camera

    @property
    def fx(self) -> float:
        """Focal length along x, pixels."""
        return self.intrinsics.fx

    @property
    def fy(self) -> float:
        """Focal length along y, pixels."""
        return self.intrinsics.fy

    @property
    def cx(self) -> float:
        """Principal point x, pixels."""
        return self.intrinsics.cx

    @property
    def cy(self) -> float:
        """Principal point y, pixels."""
        return self.intrinsics.cy

    def given(self) -> GivenCamera:
        """What this camera says, as the command line's camera options say it (``--calib FILE`` for a camera from
        a file, else ``--fx --fy --cx --cy --dist --distortion-model``, with ``--camera-height``, ``--camera-pitch``,
        ``--camera-roll`` and ``--readout-ms``)."""
        return given_camera(**self.run_options())

    def run_options(self) -> dict:
        """The camera as the fields of :class:`flowvo.drive.options.RunOptions` (``calib`` or the intrinsics,
        distortion, height, pitch, roll and readout time), so a run applies it exactly as ``flowvo run`` applies its
        flags."""
        if self.file is not None:
            path, height_m, pitch_deg, roll_deg, readout_ms = self.file
            return {"calib": path, "fx": None, "fy": None, "cx": None, "cy": None, "distortion": None,
                    "distortion_model": None, "camera_height_m": height_m, "camera_pitch_deg": pitch_deg,
                    "camera_roll_deg": roll_deg, "readout_ms": readout_ms}
        distortion = None if self.distortion.is_none else self.distortion.coefficients
        return {"calib": None, "fx": self.fx, "fy": self.fy, "cx": self.cx, "cy": self.cy, "distortion": distortion,
                "distortion_model": None if distortion is None else self.distortion.model,
                "camera_height_m": self.height_m, "camera_pitch_deg": self.pitch_deg, "camera_roll_deg": self.roll_deg,
                "readout_ms": self.readout_ms}

    def __repr__(self) -> str:
        lens = "" if self.distortion.is_none else \
            f", distortion={self.distortion.coefficients!r}, model={self.distortion.model!r}"
        where = f", file={self.file[0]!r}" if self.file is not None else ""
        return (f"Camera(fx={self.fx:g}, fy={self.fy:g}, cx={self.cx:g}, cy={self.cy:g}{lens}, "
                f"height_m={self.height_m!r}, pitch_deg={self.pitch_deg:g}, roll_deg={self.roll_deg:g}, "
                f"readout_ms={self.readout_ms:g}{where})")
