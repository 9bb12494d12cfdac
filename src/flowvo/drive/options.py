"""What to run on which drive: the options of ``flowvo run`` and ``flowvo bench``, the frame source they
name (KITTI sequence, video file or ROS bag topic), its camera, and the per-frame step of the chosen method."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from flowvo.camera import Camera
from flowvo.camera_options import GivenCamera, drive_camera, given_camera
from flowvo.errors import FlowvoError
from flowvo.methods import DEFAULT_METHOD, MethodOptions, method
from flowvo.methods.base import OdometryStep
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M
from flowvo.sources.base import FrameSource

if TYPE_CHECKING:
    from flowvo.calibration.estimated_camera import EstimatedCamera


@dataclass
class RunOptions:
    """What to run on which drive.

    Drive: ``data`` + ``sequence`` (KITTI layout), ``video``, or ``bag`` + ``topic``. Camera: ``calib`` (any
    calibration file) or ``fx, fy, cx, cy`` (bags: or ``camera_info_topic``; a video without them: the focal
    length estimated from its motion, :mod:`flowvo.calibration.estimated_camera`), ``distortion`` (+
    ``distortion_model``), ``camera_height_m``; see :mod:`flowvo.camera_options` for what overrides what.
    ``method``: a name of :data:`flowvo.methods.METHODS` (``model``: the network's checkpoint, default the
    packaged one; ``classical_scale`` "height", or "gt": GT step lengths, labelled so).
    """

    out: str
    data: str | None = None
    sequence: str | None = None
    video: str | None = None
    bag: str | None = None
    topic: str | None = None
    camera_info_topic: str | None = None
    calib: str | None = None
    fx: float | None = None
    fy: float | None = None
    cx: float | None = None
    cy: float | None = None
    distortion: tuple[float, ...] | None = None  # lens distortion coefficients (``distortion_model``'s order)
    distortion_model: str | None = None  # plumb_bob (default for --dist), rational_polynomial, equidistant
    camera_height_m: float | None = None  # above the road; None: the calibration's, else KITTI's 1.65 m
    camera_pitch_deg: float | None = None  # below the road's plane, down +; None: the calibration's, else 0
    camera_roll_deg: float | None = None  # about the optical axis, right side down +; None: the calibration's, else 0
    readout_ms: float | None = None  # a rolling shutter's, first row to last; None: the calibration's, else 0 (global)
    latency_frames: int | None = None  # the scale window's latency (frames; None: its default); windowed methods
    method: str = DEFAULT_METHOD
    model: str | None = None
    flow_method: str | None = None
    classical_scale: str = "height"
    max_frames: int | None = None
    lengths_m: tuple[float, ...] = SEGMENT_LENGTHS_M  # evaluation sub-paths (the devkit's by default)
    force: bool = False  # replace the earlier result of this drive in ``out`` (else refused)
    overlap_stages: bool = True  # read frames in a thread beside the flow stage (batch workers: one core each)
    mcap: bool = False
    frame_id: str = "odom"
    child_frame_id: str = "camera_optical"


@dataclass(frozen=True)
class Drive:
    """An opened drive: its frame source and the camera it runs with (see :mod:`flowvo.camera_options`);
    ``camera_estimate``: where the intrinsics were estimated from the motion (a video without them)."""

    source: FrameSource
    camera: Camera
    camera_estimate: EstimatedCamera | None = None


def open_drive(options: RunOptions) -> Drive:
    """The drive named by the options and its camera (validated before anything is written)."""
    drives = [name for name, given in (("--data", options.data), ("--video", options.video),
                                       ("--bag", options.bag)) if given]
    if len(drives) != 1:
        raise FlowvoError("give exactly one drive: --data ROOT --sequence NN, --video FILE or --bag PATH --topic T"
                          + (f" (got {' and '.join(drives)})" if drives else ""))
    given = given_camera(options.calib, options.fx, options.fy, options.cx, options.cy, options.distortion,
                         options.distortion_model, options.camera_height_m, options.camera_pitch_deg,
                         options.camera_roll_deg, options.readout_ms)
    source = _open_source(options, given)
    where = str(options.data or options.video or options.bag)
    estimated = None
    if options.video and given.intrinsics is None:
        from flowvo.calibration.estimated_camera import estimate_camera

        estimated = estimate_camera(source, where, distortion=given.distortion)  # a given lens (--dist) is used
    own_camera = estimated.camera if estimated else source.camera
    return Drive(source, drive_camera(given, own_camera, source.image_size_hw, where, source.camera_height_m,
                                      source.camera_pitch_deg, source.camera_roll_deg),
                 estimated)


def _open_source(options: RunOptions, given: GivenCamera) -> FrameSource:
    if options.data:
        from flowvo.kitti.sequence import KittiSequence
        from flowvo.sources.kitti_folder import KittiFolderSource

        if options.sequence is None:
            raise FlowvoError("--data needs --sequence NN")
        return KittiFolderSource(KittiSequence(options.data, options.sequence))
    if options.video:
        from flowvo.sources.video import open_video_source

        return open_video_source(options.video)
    from flowvo.sources.rosbag import open_bag_source

    if options.topic is None:
        raise FlowvoError("--bag needs --topic IMAGE_TOPIC")
    return open_bag_source(options.bag, options.topic, options.camera_info_topic, given.intrinsics)


def make_step(options: RunOptions, drive: Drive) -> OdometryStep:
    """The per-frame odometry step of ``options.method`` for this drive."""
    chosen = MethodOptions(options.method, options.model, options.flow_method, options.latency_frames,
                           options.classical_scale)
    return method(options.method).build(chosen, drive.source, drive.camera)
