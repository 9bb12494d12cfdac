"""``flowvo run``: odometry on one drive (a KITTI sequence, a video file or a ROS bag topic), with per-stage
timing and, when ground truth exists, evaluation.

Outputs in OUT: ``NAME.txt`` (KITTI poses), ``NAME.tum`` (TUM, the source's timestamps), ``timing.json``
(seconds per frame by stage, wall-clock frames per second), ``run.json`` (what ran, on what data), for the
windowed methods ``NAME_steps.csv`` (each step's length, its uncertainty and what measured it) and, with
ground truth, ``eval_NAME/`` (as ``flowvo eval`` writes it).
"""

from __future__ import annotations

from dataclasses import dataclass
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
from flowvo.report.drive_summary import drive_summary
from flowvo.report.evaluation import evaluate, save_evaluation
from flowvo.trajectory import Trajectory
from flowvo.versions import library_versions

if TYPE_CHECKING:
    from flowvo.drive.stream import StreamResult, StreamView


def run(options: RunOptions, view: StreamView | None = None) -> dict:
    """Run odometry and write every output; returns the run summary (also in run.json). ``view``: shown each
    frame and final pose as the drive streams (a live view, :mod:`flowvo.api.rerun`).

    Every input is checked (ground truth included) before the output folder is touched; the folder is
    locked while the run writes it, and an earlier result (``force``) is replaced only by the finished new
    one, whole (see :func:`flowvo.io.outputs.staged_outputs`). The Python API (:func:`flowvo.api.run`) runs
    the same three parts: :func:`start_run`, :func:`stream_run`, and :func:`save_run` when asked to save.
    """
    started = start_run(options, open_drive(options))
    produces = started.produces
    with claim_output_dir(options.out, produces, options.force, dataset=options.data) as out:
        result = stream_run(started, view)
        with staged_outputs(out, produces) as staging:
            return _write_results(options, started.drive, started.step, result, started.ground_truth, staging)


@dataclass(frozen=True)
class StartedRun:
    """A drive checked and ready to stream: its options, the drive, the method's per-frame step and the ground
    truth (read and checked before streaming, None without)."""

    options: RunOptions
    drive: Drive
    step: OdometryStep
    ground_truth: Trajectory | None

    @property
    def produces(self) -> list[str]:
        """The files and folders a run folder of this drive holds."""
        name = self.drive.source.name
        return (run_outputs(name, steps=self.step.step_records() is not None)
                + ([f"{name}.mcap"] if _writes_mcap(self.options) else []))


def start_run(options: RunOptions, drive: Drive) -> StartedRun:
    """Check the drive (frame count, ground truth, MCAP settings) and build the method's step for it."""
    source = drive.source
    where = options.data or options.video or options.bag
    if source.frame_count is not None and source.frame_count < 2:
        raise FlowvoError(f"has {source.frame_count} frame(s); odometry needs at least 2", where)
    ground_truth = source.ground_truth  # read and checked now, not after the whole drive streamed
    step = make_step(options, drive)
    _writes_mcap(options)
    return StartedRun(options, drive, step, ground_truth)


def _writes_mcap(options: RunOptions) -> bool:
    """Whether the run writes an MCAP (``--mcap``, always for a bag); the ROS extra and frame ids checked then."""
    if not (options.mcap or options.bag):
        return False
    from flowvo.ros.extra import require_ros_extra
    from flowvo.ros.odometry_mcap import check_names

    require_ros_extra("writing MCAP odometry")
    check_names(options.frame_id, options.child_frame_id)
    return True


def stream_run(started: StartedRun, view: StreamView | None = None) -> StreamResult:
    """Stream the drive through its step (:func:`flowvo.drive.stream.stream_odometry`) and check what came out."""
    from flowvo.drive.stream import stream_odometry

    options, source = started.options, started.drive.source
    where = options.data or options.video or options.bag
    result = stream_odometry(source.frames(), started.step, source.frame_count, options.max_frames, source.name,
                             overlap=options.overlap_stages, view=view)
    if result.frames < 2:  # a still image OpenCV opens as a one-frame "video"
        raise FlowvoError(f"gave {result.frames} frame(s); odometry needs at least 2", where)
    check_result_stamps(options, result)
    return result


def check_result_stamps(options: RunOptions, result: StreamResult) -> None:
    """An MCAP needs stamps it can hold: checked before anything is written."""
    if _writes_mcap(options):
        from flowvo.ros.odometry_mcap import check_stamps

        check_stamps(result.timestamps_s, options.data or options.video or options.bag)


def save_run(started: StartedRun, result: StreamResult) -> dict:
    """Write a streamed drive's outputs into ``started.options.out`` as :func:`run` does (the folder claimed and
    locked, an earlier result replaced only with ``force``, whole); returns the summary."""
    options, produces = started.options, started.produces
    check_result_stamps(options, result)
    with claim_output_dir(options.out, produces, options.force, dataset=options.data) as out, \
            staged_outputs(out, produces) as staging:
        return _write_results(options, started.drive, started.step, result, started.ground_truth, staging)


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
        "drive": drive_summary(result.T_world_cam, result.timestamps_s),  # distance, speeds, heading
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
    # what reading the drive worked around (a video that ended early) and what the method could not measure
    warnings = [*getattr(source, "warnings", []), *summary.pop("warnings", [])]
    if warnings:
        summary["warnings"] = warnings
    if ground_truth is not None:
        gt = ground_truth.subset(np.arange(result.frames)) if result.frames < len(ground_truth) else ground_truth
        evaluation = evaluate(gt, trajectory, lengths_m=options.lengths_m)
        save_evaluation(evaluation, out / f"eval_{source.name}")
        summary["metrics"] = {k: evaluation.metrics[k] for k in ("t_err_percent", "r_err_deg_per_m", "ate_rmse_m")}
    write_json_atomic(out / "run.json", summary)
    return summary
