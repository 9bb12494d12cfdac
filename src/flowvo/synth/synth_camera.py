"""The camera ``flowvo synth`` renders through: height above the road, field of view, lens, frame rate, pitch,
a car's bonnet in its bottom rows and a rolling shutter.

The defaults are KITTI's left grey camera (1.65 m, fx 718.856 px over 1241 px, no distortion, 10 Hz) and
leave renders byte-identical to the renderer before these options existed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from flowvo.camera import (
    KITTI_CAMERA_HEIGHT_M,
    NO_DISTORTION,
    LensDistortion,
    check_camera_height,
    check_camera_pitch,
    check_camera_roll,
    check_readout,
    distort_points,
    mounting_rotation,
    undistort_points,
)
from flowvo.errors import FlowvoError
from flowvo.synth.bonnet import MAX_BONNET_ROWS
from flowvo.synth.camera_path import FRAME_PERIOD_S

PATH_RATE_HZ = 1.0 / FRAME_PERIOD_S  # generated and replayed (KITTI) paths are sampled at 10 Hz
FOV_RANGE_DEG = (20.0, 150.0)  # a pinhole image beyond ~150 deg is mostly stretched periphery
FPS_RANGE_HZ = (1.0, 120.0)  # slower than 1 Hz the road leaves the view between frames; 120 Hz is a fast camera
LENS_ROUND_TRIP_PX = 0.05  # undistort-then-distort error (px) above which the lens model is not invertible there
LENS_CHECK_SAMPLES = 200  # points per centre-to-corner line of the one-to-one check


@dataclass(frozen=True)
class SynthCamera:
    """``height_m`` above the road (metres), horizontal field of view ``fov_deg`` (degrees over the image
    width; None = KITTI's focal length, ~81.6 deg), lens ``distortion``, frame rate ``fps`` (Hz) and
    ``pitch_deg``, how far the camera is pitched down from level (degrees), ``roll_deg``, how far it is rolled about
    its optical axis, right side down (degrees), ``bonnet_rows``, the share of the image height a static bonnet
    covers at the bottom (0: none; :mod:`flowvo.synth.bonnet`), and ``readout_ms``, a rolling shutter's time from
    exposing the first (top) row to the last (milliseconds; 0: a global shutter)."""

    height_m: float = KITTI_CAMERA_HEIGHT_M
    fov_deg: float | None = None
    distortion: LensDistortion = field(default=NO_DISTORTION)
    fps: float = PATH_RATE_HZ
    pitch_deg: float = 0.0
    bonnet_rows: float = field(default=0.0, repr=False)  # out of the repr, so that the digests of renders made
    # before the bonnet existed stay the same (spec_digest adds it when there is one)
    roll_deg: float = field(default=0.0, repr=False)  # likewise
    readout_ms: float = field(default=0.0, repr=False)  # likewise

    def __post_init__(self) -> None:
        check_camera_height(self.height_m, "--camera-height")
        check_camera_pitch(self.pitch_deg, "--camera-pitch")
        check_camera_roll(self.roll_deg, "--camera-roll")
        check_readout(self.readout_ms, "--readout-ms")
        if self.fov_deg is not None and not FOV_RANGE_DEG[0] <= self.fov_deg <= FOV_RANGE_DEG[1]:
            raise FlowvoError(f"--fov {self.fov_deg:g}: use a horizontal field of view in "
                              f"[{FOV_RANGE_DEG[0]:g}, {FOV_RANGE_DEG[1]:g}] degrees")
        if not FPS_RANGE_HZ[0] <= self.fps <= FPS_RANGE_HZ[1]:
            raise FlowvoError(f"--fps {self.fps:g}: use a frame rate in [{FPS_RANGE_HZ[0]:g}, {FPS_RANGE_HZ[1]:g}] Hz")
        if not 0.0 <= self.bonnet_rows <= MAX_BONNET_ROWS:
            raise FlowvoError(f"--bonnet {self.bonnet_rows:g}: use a share of the image height in "
                              f"[0, {MAX_BONNET_ROWS:g}]")
        if self.readout_ms > 1000.0 / self.fps:
            raise FlowvoError(f"--readout-ms {self.readout_ms:g}: a rolling shutter reads a frame out within the "
                              f"frame interval, {1000.0 / self.fps:g} ms at --fps {self.fps:g}")

    @property
    def is_kitti(self) -> bool:
        """True for KITTI's camera (the renders of ``flowvo synth`` without camera options)."""
        return self == SynthCamera()

    def focal_px(self, width_px: int, kitti_focal_px: float) -> float:
        """The focal length (pixels) giving ``fov_deg`` over ``width_px``, or KITTI's (scaled) one."""
        if self.fov_deg is None:
            return kitti_focal_px
        return width_px / 2.0 / math.tan(math.radians(self.fov_deg) / 2.0)

    def mounting(self) -> np.ndarray:
        """``T_level_cam`` (4, 4): the camera pitched down by ``pitch_deg`` about its x axis and rolled by
        ``roll_deg`` about its optical axis, in the frame of a level camera at the same place
        (:func:`flowvo.camera.mounting_rotation`)."""
        T = np.eye(4)
        T[:3, :3] = mounting_rotation(self.pitch_deg, self.roll_deg)
        return T

    def record(self) -> dict:
        """The camera as ``synthetic.json`` records it (the pitch, the roll, the bonnet and the readout time when it has
        them: renders of level global-shutter cameras without a bonnet made before the options keep their record, and
        resume)."""
        pitch = {"pitch_deg": self.pitch_deg} if self.pitch_deg else {}
        pitch |= {"roll_deg": self.roll_deg} if self.roll_deg else {}
        bonnet = {"bonnet_rows": self.bonnet_rows} if self.bonnet_rows else {}
        bonnet |= {"readout_ms": self.readout_ms} if self.readout_ms else {}
        return {"camera_height_m": self.height_m, "fov_deg": self.fov_deg, "distortion_model": self.distortion.model,
                "distortion": list(self.distortion.coefficients), "fps": self.fps, **pitch, **bonnet}


def check_lens(distortion: LensDistortion, K: np.ndarray, size_hw: tuple[int, int]) -> None:
    """Refuse a lens model that is not one-to-one over the image (a polynomial that folds back, as
    k1 < 0 alone does at wide angles): its rendered frames would show the scene twice. Checked on
    lines from the principal point to the four corners: the ideal radius must grow along each, and
    undistorting then distorting must give the pixels back."""
    if distortion.is_none:
        return
    h, w = size_hw
    centre = K[:2, 2]
    steps = np.linspace(0.0, 1.0, LENS_CHECK_SAMPLES)[:, None]
    lines = [centre + steps * (np.array(corner, float) - centre) for corner in ((0, 0), (w - 1, 0), (0, h - 1),
                                                                              (w - 1, h - 1))]
    for line in lines:
        ideal = undistort_points(line, K, distortion).astype(np.float64)
        back = distort_points(ideal, K, distortion)
        radius = np.linalg.norm(ideal - centre, axis=1)
        error_px = float(np.max(np.linalg.norm(back - line, axis=1)))
        if not (error_px <= LENS_ROUND_TRIP_PX and np.all(np.diff(radius) > 0)):
            raise FlowvoError(f"--distortion {' '.join(f'{c:g}' for c in distortion.coefficients)}: the "
                              f"{distortion.model} lens does not map the {w}x{h} image one-to-one (it folds "
                              "back towards the corners); use smaller coefficients or a narrower --fov")
