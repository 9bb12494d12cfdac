"""Evaluate a predicted trajectory against ground truth: the KITTI metric, ATE, RPE, per-frame errors."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flowvo.errors import FlowvoError
from flowvo.io.atomic import atomic_open, write_json_atomic
from flowvo.kitti.poses import read_kitti_poses
from flowvo.metrics import kitti_odometry as kitti
from flowvo.metrics.clock_offset import clock_offset, with_clock_offset_removed
from flowvo.metrics.error_split import MIN_DIRECTION_STEP_M, direction_offset
from flowvo.metrics.rotation_bias import MIN_ROTATION_STEP_M, rotation_bias
from flowvo.metrics.trajectory_errors import ate_rmse_m, per_frame_errors, rpe
from flowvo.trajectory import Trajectory

EVALUATION_FILES = ("metrics.json", "per_frame_errors.csv", "path_xz.png", "t_err_vs_length.png",
                    "r_err_vs_length.png", "t_err_vs_speed.png", "r_err_vs_speed.png", "frame_error_histograms.png")


@dataclass(frozen=True)
class Evaluation:
    """All numbers of one evaluation (``metrics``, JSON-ready) and the arrays behind the plots."""

    metrics: dict
    gt: Trajectory
    pred: Trajectory
    segments: kitti.SegmentErrors
    frame_errors: dict[str, np.ndarray]


def check_evaluable(gt: Trajectory, pred: Trajectory, gt_source: str | Path = "ground truth",
                    pred_source: str | Path = "prediction") -> None:
    """Raise a :class:`FlowvoError` naming the file unless ``gt`` holds every frame 0..N-1 and shares at
    least 2 frames with ``pred`` (one-frame errors and alignment need two)."""
    if not gt.is_complete:
        missing = np.setdiff1d(np.arange(gt.frame_ids[-1] + 1), gt.frame_ids)
        raise FlowvoError(f"ground truth must hold every frame 0..N-1; frame {missing[0]} is missing", gt_source)
    shared = len(np.intersect1d(gt.frame_ids, pred.frame_ids))
    if shared < 2:
        raise FlowvoError(f"shares {shared} frame(s) with the ground truth ({len(gt)} frames from 0); the "
                          "evaluation needs at least 2", pred_source)


def evaluate(gt: Trajectory, pred: Trajectory, alignment: str = "none",
             lengths_m: tuple[float, ...] = kitti.SEGMENT_LENGTHS_M) -> Evaluation:
    """The KITTI odometry metric on sub-paths of ``lengths_m`` (default the devkit's 100..800 m; needs no
    alignment), ATE after ``alignment``, and one-frame RPE."""
    check_evaluable(gt, pred)
    lengths_m = tuple(float(L) for L in lengths_m)
    segments = kitti.sequence_segment_errors(gt, pred, lengths_m)
    if len(segments):
        metrics = kitti.summarize(segments, lengths_m)
    else:  # shorter than the shortest sub-path: the metric is undefined, ATE and RPE still are
        metrics = {"t_err_percent": None, "r_err_deg_per_m": None, "r_err_deg_per_100m": None, "segments": 0,
                   "segment_lengths_m": list(lengths_m), "per_length": [], "per_speed": [],
                   "note": f"no segment of {format_lengths(lengths_m)}: path shorter than {min(lengths_m):g} m"}
    metrics["devkit_lengths"] = lengths_m == kitti.SEGMENT_LENGTHS_M
    metrics["units"] = {
        "t_err_percent": "% of segment length",
        "r_err_deg_per_m": "degrees per metre",
        "r_err_deg_per_100m": "degrees per 100 m",
        "ate_rmse_m": "metres",
    }
    metrics["ate_alignment"] = alignment
    metrics["ate_rmse_m"] = ate_rmse_m(gt, pred, alignment)
    metrics.update(rpe(gt, pred))
    metrics["frames_gt"] = len(gt)
    metrics["frames_predicted"] = int(np.isin(pred.frame_ids, gt.frame_ids).sum())
    metrics["path_length_m"] = float(kitti.trajectory_distances(gt.positions)[-1])
    metrics["direction_offset_deg"] = direction_offset_record(gt, pred)
    metrics["rotation_per_step_mdeg"] = rotation_bias_record(gt, pred)
    metrics["clock_offset"] = clock_offset_record(gt, pred, lengths_m)
    return Evaluation(metrics, gt, pred, segments, per_frame_errors(gt, pred))


def direction_offset_record(gt: Trajectory, pred: Trajectory) -> dict:
    """The prediction's direction of travel against the truth's over the frames both hold
    (:func:`flowvo.metrics.error_split.direction_offset`: medians over the steps between consecutive shared frames
    of :data:`MIN_DIRECTION_STEP_M` or more), degrees, JSON-ready (None where no step counts): a constant offset is
    what a truth given in a camera frame turned against the images' own puts on every step."""
    shared = np.intersect1d(gt.frame_ids, pred.frame_ids)
    offset = direction_offset(gt.T_world_cam[np.searchsorted(gt.frame_ids, shared)],
                              pred.T_world_cam[np.searchsorted(pred.frame_ids, shared)])
    counted = offset.steps > 0
    return {"azimuth_right": offset.azimuth_deg if counted else None,
            "elevation_up": offset.elevation_deg if counted else None, "steps": offset.steps,
            "min_step_m": MIN_DIRECTION_STEP_M}


def rotation_bias_record(gt: Trajectory, pred: Trajectory) -> dict:
    """The prediction's step rotations against the truth's over the frames both hold
    (:func:`flowvo.metrics.rotation_bias.rotation_bias`, over the steps between consecutive shared frames on which
    the truth moved :data:`MIN_ROTATION_STEP_M` or more), JSON-ready: the mean error per step about the camera's
    axes, millidegrees (a bias adds up along a drive), and the slope of the prediction's yaw per step against the
    truth's (under 1: turns read short; None where no step turned)."""
    shared = np.intersect1d(gt.frame_ids, pred.frame_ids)
    bias = rotation_bias(gt.T_world_cam[np.searchsorted(gt.frame_ids, shared)],
                         pred.T_world_cam[np.searchsorted(pred.frame_ids, shared)])
    pitch, yaw, roll = (float(value) for value in bias.mean_error_mdeg)
    return {"pitch_up": pitch, "yaw_right": yaw, "roll_right_down": roll, "steps": bias.steps,
            "yaw_slope": None if np.isnan(bias.yaw_slope) else bias.yaw_slope,
            "turning_steps": bias.turning_steps, "min_step_m": MIN_ROTATION_STEP_M}


def clock_offset_record(gt: Trajectory, pred: Trajectory, lengths_m: tuple[float, ...]) -> dict | None:
    """How far the prediction's step rotations lead the truth's (:mod:`flowvo.metrics.clock_offset`), JSON-ready:
    ``frames`` (positive: each image later than its true pose; None where not read) with its standard error, the
    share of the step rotation errors' variance it explains, and the KITTI metric of the prediction read at the
    truth's times (None where undefined). None unless the prediction holds the truth's frames 0..N-1 from the first
    on, one after another."""
    shared = np.intersect1d(gt.frame_ids, pred.frame_ids)
    if len(shared) < 2 or shared[0] != 0 or shared[-1] != len(shared) - 1:
        return None
    T_gt, T_pred = gt.T_world_cam[: len(shared)], pred.T_world_cam[np.searchsorted(pred.frame_ids, shared)]
    offset = clock_offset(T_gt, T_pred)
    record = {"frames": None if np.isnan(offset.frames) else offset.frames,
              "standard_error": None if np.isnan(offset.standard_error) else offset.standard_error,
              "explained": None if np.isnan(offset.explained) else offset.explained, "steps": offset.steps,
              "t_err_percent": None, "r_err_deg_per_m": None}
    if record["frames"] is None:
        return record
    segments = kitti.sequence_segment_errors(Trajectory.from_poses(T_gt),
                                             Trajectory.from_poses(with_clock_offset_removed(T_pred, offset)),
                                             lengths_m)
    if len(segments):
        summary = kitti.summarize(segments, lengths_m)
        record["t_err_percent"], record["r_err_deg_per_m"] = summary["t_err_percent"], summary["r_err_deg_per_m"]
    return record


def format_lengths(lengths_m: tuple[float, ...]) -> str:
    """'100..800 m' for the devkit's lengths, else the list, e.g. '10, 20, 30 m'."""
    if tuple(lengths_m) == kitti.SEGMENT_LENGTHS_M:
        return "100..800 m"
    return ", ".join(f"{L:g}" for L in lengths_m) + " m"


def evaluate_files(gt_path: str | Path, pred_path: str | Path, alignment: str = "none",
                   lengths_m: tuple[float, ...] = kitti.SEGMENT_LENGTHS_M) -> Evaluation:
    """Read two KITTI pose files and evaluate; the files are named in the metrics."""
    gt, pred = read_kitti_poses(gt_path), read_kitti_poses(pred_path)
    check_evaluable(gt, pred, gt_path, pred_path)
    beyond = int((pred.frame_ids >= len(gt)).sum())
    if beyond:
        raise FlowvoError(f"has {beyond} pose(s) beyond the ground truth's {len(gt)} frames (frames "
                          f"{len(gt)}..{pred.frame_ids[-1]}): not a prediction of this sequence?", pred_path)
    evaluation = evaluate(gt, pred, alignment, lengths_m)
    evaluation.metrics["gt_file"] = str(gt_path)
    evaluation.metrics["pred_file"] = str(pred_path)
    return evaluation


def pooled_summary(evaluations: list[Evaluation]) -> dict:
    """The multi-sequence KITTI average: all segments of all sequences together (evaluated on the same
    sub-path lengths)."""
    lengths_m = tuple(evaluations[0].metrics.get("segment_lengths_m", kitti.SEGMENT_LENGTHS_M))
    return kitti.summarize(kitti.SegmentErrors.concatenate([e.segments for e in evaluations]), lengths_m)


def format_table(metrics: dict) -> str:
    """A short human-readable table of the headline numbers, with units."""
    lengths_m = tuple(metrics.get("segment_lengths_m", kitti.SEGMENT_LENGTHS_M))
    sub_paths = ("sub-paths", format_lengths(lengths_m) + ("" if metrics.get("devkit_lengths", True)
                                                           else "  (not the devkit's 100..800 m)"))
    if metrics["t_err_percent"] is None:
        kitti_rows = [sub_paths, ("t_err", f"n/a (path shorter than {min(lengths_m):g} m)"), ("r_err", "n/a")]
    else:
        kitti_rows = [
            sub_paths,
            ("t_err", f"{metrics['t_err_percent']:.4f} %"),
            ("r_err", f"{metrics['r_err_deg_per_m']:.6f} deg/m  ({metrics['r_err_deg_per_100m']:.4f} deg/100m)"),
        ]
    rows = [
        *kitti_rows,
        ("segments", str(metrics["segments"])),
        (f"ATE RMSE (align {metrics['ate_alignment']})", f"{metrics['ate_rmse_m']:.3f} m"),
        ("RPE trans RMSE (1 frame)", f"{metrics['rpe_trans_rmse_m']:.4f} m"),
        ("RPE rot RMSE (1 frame)", f"{metrics['rpe_rot_rmse_deg']:.4f} deg"),
    ]
    offset = metrics.get("direction_offset_deg")
    if offset and offset["steps"]:
        rows.append(("direction offset", f"azimuth {offset['azimuth_right']:+.3f} deg (right +), elevation "
                                         f"{offset['elevation_up']:+.3f} deg (up +), {offset['steps']} steps"))
    rotation = metrics.get("rotation_per_step_mdeg")
    if rotation and rotation["steps"]:
        gain = "" if rotation["yaw_slope"] is None else \
            f"; yaw {rotation['yaw_slope']:.4f} of the truth's (slope)"
        pitch, yaw, roll = (round(rotation[key], 2) + 0.0 for key in ("pitch_up", "yaw_right", "roll_right_down"))
        rows.append(("rotation per step", f"pitch {pitch:+.2f} (up +), yaw {yaw:+.2f} (right +), roll {roll:+.2f} mdeg "
                                          f"(right down +), {rotation['steps']} steps{gain}"))  # + 0.0: no -0.00
    clock = metrics.get("clock_offset")
    if clock and clock["frames"] is not None:
        rescored = "" if clock["t_err_percent"] is None else \
            f"; read at the truth's times {clock['t_err_percent']:.4f} % / {clock['r_err_deg_per_m']:.6f} deg/m"
        rows.append(("clock offset", f"{clock['frames']:+.3f} +- {clock['standard_error']:.3f} frames (images after "
                                     "their true poses +), "
                                     f"{100 * clock['explained']:.0f} % of the step rotation errors{rescored}"))
    if metrics["frames_predicted"] < metrics["frames_gt"]:
        rows.append(("frames", f"{metrics['frames_predicted']} of the ground truth's {metrics['frames_gt']} "
                               "predicted (only those scored)"))
    width = max(len(name) for name, _ in rows)
    lines = [f"{name.ljust(width)}  {value}" for name, value in rows]
    lines.append("")
    lines.append("length_m   t_err_%   r_err_deg/m  segments")
    for row in metrics["per_length"]:
        lines.append(
            f"{row['length_m']:8.0f}  {row['t_err_percent']:8.3f}  {row['r_err_deg_per_m']:11.6f}  {row['segments']:8d}"
        )
    return "\n".join(lines)


def save_evaluation(evaluation: Evaluation, out_dir: str | Path) -> list[Path]:
    """Write metrics.json, per_frame_errors.csv and the PNG plots into ``out_dir``; returns the files."""
    from flowvo.report import plots

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out / "metrics.json", evaluation.metrics)
    frame = evaluation.frame_errors
    table = np.stack([frame["frame_id"], frame["translation_error_m"], frame["rotation_error_deg"]], 1)
    with atomic_open(out / "per_frame_errors.csv") as handle:
        handle.write("frame_id,translation_error_m,rotation_error_deg\n")
        for row in table:
            handle.write(f"{int(row[0])},{row[1]:.6f},{row[2]:.6f}\n")
    return [out / "metrics.json", out / "per_frame_errors.csv", *plots.save_evaluation_plots(evaluation, out)]
