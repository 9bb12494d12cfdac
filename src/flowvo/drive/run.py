"""``flowvo run``: odometry on one drive (a KITTI sequence, a video file or a ROS bag topic), with per-stage
timing and, when ground truth exists, evaluation.

Outputs in OUT: ``NAME.txt`` (KITTI poses), ``NAME.tum`` (TUM, the source's timestamps), ``timing.json``
(seconds per frame by stage, wall-clock frames per second), ``run.json`` (what ran, on what data), for the
windowed methods ``NAME_steps.csv`` (each step's length, its uncertainty and what measured it) and, with
ground truth, ``eval_NAME/`` (as ``flowvo eval`` writes it).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from flowvo.drive.options import Drive, RunOptions, make_step, open_drive
from flowvo.drive.steps_csv import write_steps_csv
from flowvo.errors import FlowvoError
from flowvo.io.atomic import write_json_atomic
from flowvo.io.outputs import claim_output_dir, run_outputs, staged_outputs, steps_csv_name
from flowvo.kitti.poses import write_kitti_poses, write_tum_trajectory
from flowvo.methods.base import OdometryStep
from flowvo.odometry.covariance import records_covariances
from flowvo.report.evaluation import evaluate, save_evaluation
from flowvo.trajectory import Trajectory
from flowvo.versions import library_versions

if TYPE_CHECKING:
    from flowvo.drive.stream import StreamResult


def run(options: RunOptions) -> dict:
    """Run odometry and write every output; returns the run summary (also in run.json).

    Every input is checked (ground truth included) before the output folder is touched; the folder is
    locked while the run writes it, and an earlier result (``force``) is replaced only by the finished new
    one, whole (see :func:`flowvo.io.outputs.staged_outputs`).
    """
    from flowvo.drive.stream import stream_odometry

    drive = open_drive(options)
    source = drive.source
    where = options.data or options.video or options.bag
    if source.frame_count is not None and source.frame_count < 2:
        raise FlowvoError(f"has {source.frame_count} frame(s); odometry needs at least 2", where)
    ground_truth = source.ground_truth  # read and checked now, not after the whole drive streamed
    step = make_step(options, drive)
    write_mcap = options.mcap or bool(options.bag)
    if write_mcap:
        from flowvo.ros.extra import require_ros_extra
        from flowvo.ros.odometry_mcap import check_names

        require_ros_extra("writing MCAP odometry")
        check_names(options.frame_id, options.child_frame_id)
    produces = (run_outputs(source.name, steps=step.step_records() is not None)
                + ([f"{source.name}.mcap"] if write_mcap else []))
    with claim_output_dir(options.out, produces, options.force, dataset=options.data) as out:
        result = stream_odometry(source.frames(), step, source.frame_count, options.max_frames, source.name,
                                 overlap=options.overlap_stages)
        if result.frames < 2:  # a still image OpenCV opens as a one-frame "video"
            raise FlowvoError(f"gave {result.frames} frame(s); odometry needs at least 2", where)
        if write_mcap:
            from flowvo.ros.odometry_mcap import check_stamps

            check_stamps(result.timestamps_s, where)
        with staged_outputs(out, produces) as staging:
            return _write_results(options, drive, step, result, ground_truth, staging)


def _write_results(options: RunOptions, drive: Drive, step: OdometryStep, result: StreamResult,
                   ground_truth: Trajectory | None, out: Path) -> dict:
    """Write poses, timing, MCAP, evaluation and run.json into ``out``; returns the summary."""
    from flowvo.drive.stream import timing_report

    source = drive.source
    trajectory = Trajectory.from_poses(result.T_world_cam)
    write_kitti_poses(out / f"{source.name}.txt", trajectory)
    write_tum_trajectory(out / f"{source.name}.tum", trajectory, result.timestamps_s)
    timing = timing_report(result)
    write_json_atomic(out / "timing.json", timing)
    records = step.step_records()
    if records is not None:
        write_steps_csv(out / steps_csv_name(source.name), records, result.frames)
    summary = {
        "label": step.label,
        "method": options.method,
        "sequence": source.name,
        "data": str(Path(options.data).resolve()) if options.data else None,
        "source": {"video": options.video, "bag": options.bag, "topic": options.topic},
        "synthetic": source.is_synthetic,
        "frames": result.frames,
        "poses": f"{source.name}.txt",
        "camera": drive.camera.record(),
        "frames_per_second": timing["frames_per_second"],
        "latency_frames": step.latency_frames,  # each pose is final this many frames after its own arrives
        "steps": steps_csv_name(source.name) if records is not None else None,
        "lengths_m": list(options.lengths_m),
        "versions": library_versions(),  # results are comparable only between the same versions
    }
    if drive.camera_estimate is not None:
        summary["camera"]["estimate"] = drive.camera_estimate.record()
    if options.mcap or options.bag:
        from flowvo.ros.odometry_mcap import write_odometry_mcap

        write_odometry_mcap(out / f"{source.name}.mcap", result.timestamps_s, result.T_world_cam,
                            frame_id=options.frame_id, child_frame_id=options.child_frame_id,
                            exact_stamps_ns=None if source.stamps_ns is None else source.stamps_ns[:result.frames],
                            covariances=None if records is None else records_covariances(result.T_world_cam, records))
        summary["mcap"] = f"{source.name}.mcap"
    summary.update(step.summary())
    if ground_truth is not None:
        gt = ground_truth.subset(np.arange(result.frames)) if result.frames < len(ground_truth) else ground_truth
        evaluation = evaluate(gt, trajectory, lengths_m=options.lengths_m)
        save_evaluation(evaluation, out / f"eval_{source.name}")
        summary["metrics"] = {k: evaluation.metrics[k] for k in ("t_err_percent", "r_err_deg_per_m", "ate_rmse_m")}
    write_json_atomic(out / "run.json", summary)
    return summary
