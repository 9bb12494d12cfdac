"""What to run on which drive: the options of ``flowvo run`` and ``flowvo bench``, the frame source they
name (KITTI sequence, video file or ROS bag topic) and the per-frame step of the chosen method."""

from __future__ import annotations

from dataclasses import dataclass

from flowvo.errors import FlowvoError
from flowvo.geometry import planar_targets
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M
from flowvo.sources.base import FrameSource

METHODS = ("flowvo", "flowvo-geometry", "cnn", "classical")


@dataclass
class RunOptions:
    """What to run on which drive.

    Drive: ``data`` + ``sequence`` (KITTI layout), ``video``, or ``bag`` + ``topic``; intrinsics for video
    and bags from ``calib`` or ``fx, fy, cx, cy`` (bags: or ``camera_info_topic``).
    ``method``: "flowvo" (default, no ground truth), "cnn" (the thesis network, ``model`` or the packaged
    one) or "classical" (``classical_scale`` "height", or "gt": GT step lengths, labelled so).
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
    method: str = "flowvo"
    model: str | None = None
    flow_method: str | None = None
    classical_scale: str = "height"
    max_frames: int | None = None
    lengths_m: tuple[float, ...] = SEGMENT_LENGTHS_M  # evaluation sub-paths (the devkit's by default)
    label: str | None = None
    force: bool = False  # replace the earlier result of this drive in ``out`` (else refused)
    overlap_stages: bool = True  # read frames in a thread beside the flow stage (batch workers: one core each)
    mcap: bool = False
    frame_id: str = "odom"
    child_frame_id: str = "camera_optical"


def open_source(options: RunOptions) -> FrameSource:
    """The drive named by the options (validated before anything is written)."""
    from flowvo.sources.intrinsics import intrinsics_from_options

    drives = [name for name, given in (("--data", options.data), ("--video", options.video),
                                       ("--bag", options.bag)) if given]
    if len(drives) != 1:
        raise FlowvoError("give exactly one drive: --data ROOT --sequence NN, --video FILE or --bag PATH --topic T"
                          + (f" (got {' and '.join(drives)})" if drives else ""))
    intrinsics = intrinsics_from_options(options.calib, options.fx, options.fy, options.cx, options.cy)
    if options.data:
        from flowvo.kitti.sequence import KittiSequence
        from flowvo.sources.kitti_folder import KittiFolderSource

        if options.sequence is None:
            raise FlowvoError("--data needs --sequence NN")
        if intrinsics is not None:
            raise FlowvoError("--calib/--fx.. are for --video and --bag; a KITTI sequence has its calib.txt")
        return KittiFolderSource(KittiSequence(options.data, options.sequence))
    if options.video:
        from flowvo.sources.video import open_video_source

        return open_video_source(options.video, intrinsics)
    from flowvo.sources.rosbag import open_bag_source

    if options.topic is None:
        raise FlowvoError("--bag needs --topic IMAGE_TOPIC")
    return open_bag_source(options.bag, options.topic, options.camera_info_topic, intrinsics)


def make_step(options: RunOptions, source: FrameSource):
    """The per-frame odometry step of ``options.method`` for this source."""
    from flowvo import odometry_step

    if options.method in ("flowvo", "flowvo-geometry"):
        fallback = cnn_step(options, source) if options.method == "flowvo" else None
        return odometry_step.FlowGeometryStep(source.intrinsics, source.image_size_hw,
                                              flow_method=options.flow_method or odometry_step.DEFAULT_FLOW_METHOD,
                                              fallback=fallback)
    if options.method == "cnn":
        return cnn_step(options, source, options.flow_method)
    if options.method == "classical":
        steps = None
        if options.classical_scale == "gt":
            if source.ground_truth is None:
                raise FlowvoError("--scale-from gt needs ground-truth poses, and this drive has none")
            steps = planar_targets(source.ground_truth.T_world_cam)[:, 0]
        return odometry_step.ClassicalStep(source.intrinsics, steps)
    raise FlowvoError(f"unknown method {options.method!r}; choose one of {', '.join(METHODS)}")


def cnn_step(options: RunOptions, source: FrameSource, flow_method: str | None = None):
    """The thesis network's step (``options.model`` or the packaged model) with the flow it was trained on."""
    from flowvo import odometry_step
    from flowvo.model.checkpoint import load_model, packaged_model_path

    model, normalization, state = load_model(options.model or packaged_model_path())
    flow_method = flow_method or state.get("train_config", {}).get("flow_method", "dis-medium")
    trained_hw = state.get("flow_size_hw") or [188, 620]
    return odometry_step.CnnStep(source.intrinsics, source.image_size_hw, model, normalization, flow_method,
                                 working_width=int(trained_hw[1]))
