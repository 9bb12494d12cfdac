"""``flowvo run``: odometry on one drive (a KITTI sequence, a video file or a ROS bag topic), with per-stage
timing and, when ground truth exists, evaluation.

Outputs in OUT: ``NAME.txt`` (KITTI poses), ``NAME.tum`` (TUM, the source's timestamps), ``timing.json``
(seconds per frame by stage, wall-clock frames per second), ``run.json`` (what ran, on what data) and,
with ground truth, ``eval_NAME/`` (as ``flowvo eval`` writes it).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flowvo.atomic import write_json_atomic
from flowvo.errors import FlowvoError
from flowvo.evaluation import evaluate, save_evaluation
from flowvo.geometry import planar_targets
from flowvo.kitti.poses import write_kitti_poses, write_tum_trajectory
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M
from flowvo.outputs import prepare_output_dir, run_outputs
from flowvo.sources.base import FrameSource
from flowvo.trajectory import Trajectory

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
    method: str = "flowvo"
    model: str | None = None
    flow_method: str | None = None
    classical_scale: str = "height"
    max_frames: int | None = None
    lengths_m: tuple[float, ...] = SEGMENT_LENGTHS_M  # evaluation sub-paths (the devkit's by default)
    label: str | None = None
    force: bool = False  # replace the earlier result of this drive in ``out`` (else refused)
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


def run(options: RunOptions) -> dict:
    """Run odometry and write every output; returns the run summary (also in run.json)."""
    from flowvo.stream import stream_odometry

    source = open_source(options)
    if source.frame_count is not None and source.frame_count < 2:
        raise FlowvoError(f"has {source.frame_count} frame(s); odometry needs at least 2", source.name)
    step = make_step(options, source)
    write_mcap = options.mcap or bool(options.bag)
    produces = run_outputs(source.name) + ([f"{source.name}.mcap"] if write_mcap else [])
    out = prepare_output_dir(options.out, produces, options.force, dataset=options.data)
    result = stream_odometry(source.frames(), step, source.frame_count, options.max_frames, source.name)
    trajectory = Trajectory.from_poses(result.T_world_cam)
    write_kitti_poses(out / f"{source.name}.txt", trajectory)
    write_tum_trajectory(out / f"{source.name}.tum", trajectory, result.timestamps_s)
    timing = timing_report(result)
    write_json_atomic(out / "timing.json", timing)
    summary = {
        "label": options.label or step.label,
        "method": options.method,
        "sequence": source.name,
        "data": str(Path(options.data).resolve()) if options.data else None,
        "source": {"video": options.video, "bag": options.bag, "topic": options.topic},
        "synthetic": source.is_synthetic,
        "frames": result.frames,
        "poses": f"{source.name}.txt",
        "intrinsics": dataclasses.asdict(source.intrinsics),
        "frames_per_second": timing["frames_per_second"],
    }
    if write_mcap:
        from flowvo.ros.odometry_mcap import write_odometry_mcap

        write_odometry_mcap(out / f"{source.name}.mcap", result.timestamps_s, result.T_world_cam,
                            frame_id=options.frame_id, child_frame_id=options.child_frame_id)
        summary["mcap"] = f"{source.name}.mcap"
    if getattr(step, "fallback", None) is not None:
        summary["network_distance_steps"] = step.fallback_frames  # steps without a trustworthy road plane
    if options.method == "classical":
        summary["scale_source"] = options.classical_scale
    if source.ground_truth is not None:
        gt = source.ground_truth.subset(np.arange(result.frames)) if result.frames < len(source.ground_truth) \
            else source.ground_truth
        evaluation = evaluate(gt, trajectory, lengths_m=options.lengths_m)
        save_evaluation(evaluation, out / f"eval_{source.name}")
        summary["metrics"] = {k: evaluation.metrics[k] for k in ("t_err_percent", "r_err_deg_per_m", "ate_rmse_m")}
    write_json_atomic(out / "run.json", summary)
    return summary


def timing_report(result) -> dict:
    """Seconds per frame by stage (stages overlap: image reading runs in its own thread), and the
    wall-clock total per frame and frames per second of the whole stream."""
    frames = max(result.frames - 1, 1)
    per_frame = {stage: seconds / frames for stage, seconds in result.stage_seconds.items()}
    per_frame["total"] = result.wall_seconds / frames
    return {"seconds_per_frame": per_frame, "frames": result.frames,
            "frames_per_second": 1.0 / per_frame["total"] if per_frame["total"] > 0 else None,
            "note": "image_read runs in a reader thread, overlapped with the other stages; total is wall-clock"}
