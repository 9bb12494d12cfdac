"""Print where a run's error comes from, for any drive with ground truth (markdown tables).

The error split: the KITTI metric (t_err %, r_err deg/m) of the run as it is, of its rotations and directions
of travel with the true step lengths, of the true rotations and directions with its step lengths, of its step
lengths all divided by its whole path ratio (its lengths' overall bias removed), of the run and of its rotations
and directions with the true lengths once their median direction offset against the truth is turned back, of the
run with its mean rotation error per step removed or with its yaw per step divided by the slope below, and of the run
read at the truth's times (the clock offset below taken out), each with its path length over the true one; then that
offset (azimuth and elevation, degrees), the mean rotation error per step about the camera's axes (pitch, yaw, roll),
the slope of the run's yaw against the truth's, the truth's clock against the images'
(:mod:`flowvo.metrics.clock_offset`), and the run's turns over the truth's by true speed
(:func:`flowvo.metrics.rotation_bias.turn_reading_by_speed`). Then, per stretch of ``--stretch`` frames and per
``--stretch-m`` metres of true path, the estimated path over the true one beside the stretch's true length, mean
speed (m/s) and heading change (degrees, positive to the right).
The maths: :mod:`flowvo.metrics.error_split`.

Usage: python scripts/drive_diagnostic.py GT.txt PRED.txt [--times times.txt] [--stretch 50] [--stretch-m 100]
           [--lengths 100 200 ...]
(KITTI pose files of the same frames, e.g. ``poses/03.txt`` and a ``flowvo run`` output; ``times.txt`` gives the
frames' times in seconds, else 0.1 s a frame; ``--lengths`` the sub-paths, the devkit's 100..800 m by default.)
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from flowvo.errors import FlowvoError
from flowvo.io.text_numbers import parse_float
from flowvo.kitti.poses import read_kitti_poses
from flowvo.metrics.clock_offset import clock_offset
from flowvo.metrics.error_split import (
    MIN_DIRECTION_STEP_M,
    Stretch,
    direction_offset,
    distance_bounds,
    error_split,
    frame_bounds,
    kitti_errors,
    stretches,
)
from flowvo.metrics.kitti_odometry import FRAME_PERIOD_S, SEGMENT_LENGTHS_M
from flowvo.metrics.rotation_bias import (
    MIN_ROTATION_STEP_M,
    MIN_TURN_RAD,
    TurnReading,
    rotation_bias,
    turn_reading_by_speed,
)

SPLIT_ROWS = {"run": "the run", "true_lengths": "its rotations and directions, true step lengths",
              "true_rotations": "true rotations and directions, its step lengths",
              "one_factor": "its step lengths / its path ratio (one factor)",
              "offset_removed": "the run, its direction offset removed",
              "true_lengths_offset_removed": "its rotations and directions, offset removed, true step lengths",
              "rotation_bias_removed": "the run, its mean rotation error per step removed",
              "yaw_slope_removed": "the run, its yaw per step over its yaw slope (turns at their true size)",
              "clock_offset_removed": "the run read at the truth's times (its clock offset taken out)"}


def read_times(path: Path, n_frames: int) -> np.ndarray:
    """One time in seconds per frame, increasing (a KITTI ``times.txt``)."""
    try:
        lines = [line.strip() for line in path.read_text(encoding="utf-8", errors="replace").splitlines()]
    except OSError as error:
        raise FlowvoError(f"cannot read the times: {error.strerror}", path) from None
    values = []
    for number, line in enumerate(lines, start=1):
        if not line:
            continue
        try:
            values.append(parse_float(line))
        except ValueError:
            raise FlowvoError("expected one time in seconds per line", path, number) from None
        if not math.isfinite(values[-1]) or (len(values) > 1 and values[-1] <= values[-2]):
            raise FlowvoError("times must be finite seconds, increasing", path, number)
    if len(values) != n_frames:
        raise FlowvoError(f"has {len(values)} times for {n_frames} frames", path)
    return np.asarray(values)


def stretch_table(title: str, rows: list[Stretch]) -> list[str]:
    lines = [f"**{title}**", "", "| frames | true path m | mean speed m/s | turn deg | estimated / true path |",
             "| --- | --- | --- | --- | --- |"]
    for row in rows:
        ratio = "-" if math.isnan(row.path_ratio) else f"{row.path_ratio:.3f}"
        lines.append(f"| {row.first_frame}-{row.last_frame} | {row.true_length_m:.1f} | {row.mean_speed_mps:.1f} "
                     f"| {row.turn_deg:+.1f} | {ratio} |")
    return [*lines, ""]


def turn_table(readings: list[TurnReading]) -> list[str]:
    """The turns by speed (:func:`flowvo.metrics.rotation_bias.turn_reading_by_speed`) as a markdown table."""
    lines = [f"**Turns by speed** (the steps turning {np.degrees(MIN_TURN_RAD):g} degrees or more, by their true "
             "speed: the run's yaw over the truth's, each step signed as the truth turns)", "",
             "| speed m/s | turning steps | true turn deg | run's turn / truth's |", "| --- | --- | --- | --- |"]
    lines += [f"| {row.low_mps:g}-{row.high_mps:g} | {row.steps} | {row.true_turn_deg:.1f} | {row.read:.4f} |"
              for row in readings]
    return [*lines, ""]


def report(gt_path: Path, pred_path: Path, times_path: Path | None, stretch_frames: int, stretch_m: float,
           lengths_m: tuple[float, ...]) -> list[str]:
    """The diagnostic's markdown lines."""
    T_gt = read_kitti_poses(gt_path).T_world_cam
    prediction = read_kitti_poses(pred_path)
    if len(prediction) != len(T_gt) or not prediction.is_complete:
        raise FlowvoError(f"holds {len(prediction)} poses (frames {prediction.frame_ids[0]}-"
                          f"{prediction.frame_ids[-1]}); the truth has every one of {len(T_gt)} frames", pred_path)
    T_pred = prediction.T_world_cam
    times_s = None if times_path is None else read_times(times_path, len(T_gt))
    try:
        split = error_split(T_gt, T_pred, lengths_m)
        per_length = kitti_errors(T_gt, T_pred, lengths_m)["per_length"]
    except ValueError as error:
        raise FlowvoError(f"{error}; give shorter --lengths", gt_path) from None
    whole = stretches(T_gt, T_pred, [(0, len(T_gt) - 1)], times_s)[0]
    lines = [f"Truth {gt_path}, run {pred_path}: {len(T_gt)} frames, true path {whole.true_length_m:.1f} m, "
             f"estimated {whole.estimated_length_m:.1f} m (ratio {whole.path_ratio:.4f}), mean speed "
             f"{whole.mean_speed_mps:.1f} m/s, turn {whole.turn_deg:+.1f} deg.", "",
             "**Error split** (KITTI metric, sub-paths of "
             + ", ".join(f"{row['length_m']:g} m ({row['segments']} segments)" for row in per_length) + ")", "",
             "| poses | t_err % | r_err deg/m | segments | path / true |", "| --- | --- | --- | --- | --- |"]
    for name, label in SPLIT_ROWS.items():
        row = split[name]
        lines.append(f"| {label} | {row['t_err_percent']:.2f} | {row['r_err_deg_per_m']:.4f} | {row['segments']} "
                     f"| {row['path_ratio']:.4f} |")
    offset = direction_offset(T_gt, T_pred)
    lines += ["", f"**Direction offset** (the run's direction of travel against the truth's, medians over "
              f"{offset.steps} steps of {MIN_DIRECTION_STEP_M:g} m or more, camera frame): azimuth "
              f"{offset.azimuth_deg:+.3f} deg (positive right), elevation {offset.elevation_deg:+.3f} deg (positive "
              "up). A constant offset is also what a truth given in a camera frame turned against the images' own puts "
              "on every step.", ""]
    bias = rotation_bias(T_gt, T_pred)
    pitch, yaw, roll = (round(float(value), 2) + 0.0 for value in bias.mean_error_mdeg)  # + 0.0: no -0.00
    lines += [f"**Rotation per step** (the run's step rotations against the truth's, mean error over {bias.steps} "
              f"steps of {MIN_ROTATION_STEP_M:g} m or more, millidegrees a step): pitch {pitch:+.2f} (positive nose "
              f"up), yaw {yaw:+.2f} (positive right), roll {roll:+.2f} (positive right side down). The slope of the "
              f"run's yaw per step against the truth's (carried by the {bias.turning_steps} steps turning "
              f"{np.degrees(MIN_TURN_RAD):g} degrees or more; under 1: turns read short): {bias.yaw_slope:.4f}.", ""]
    clock = clock_offset(T_gt, T_pred)
    lines += [f"**Clock offset** (how far the run's step rotations lead the truth's, from {clock.steps} steps: the "
              "truth's clock against the images', not the method's error): "
              + ("not read (no change of the true rotation between moving steps)." if math.isnan(clock.frames) else
                 f"{clock.frames:+.3f} +- {clock.standard_error:.3f} frames (positive: each image later than its true "
                 f"pose), {100 * clock.explained:.0f} % of the step rotation errors' variance."), ""]
    lines += turn_table(turn_reading_by_speed(T_gt, T_pred, FRAME_PERIOD_S * np.arange(len(T_gt)) if times_s is None
                                              else times_s))
    lines += stretch_table(f"Per {stretch_frames} frames", stretches(T_gt, T_pred, frame_bounds(len(T_gt),
                                                                                               stretch_frames),
                                                                     times_s))
    lines += stretch_table(f"Per {stretch_m:g} m", stretches(T_gt, T_pred, distance_bounds(T_gt, stretch_m), times_s))
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("gt", type=Path, help="ground-truth KITTI pose file")
    parser.add_argument("pred", type=Path, help="the run's KITTI pose file (the same frames)")
    parser.add_argument("--times", type=Path, help="times.txt: one time in seconds per frame (default 0.1 s a frame)")
    parser.add_argument("--stretch", type=int, default=50, help="frames per stretch (default 50)")
    parser.add_argument("--stretch-m", type=float, default=100.0, help="metres of true path per stretch (default 100)")
    parser.add_argument("--lengths", type=float, nargs="+", default=list(SEGMENT_LENGTHS_M),
                        help="sub-path lengths of the KITTI metric, m (default the devkit's 100..800)")
    args = parser.parse_args(argv)
    if args.stretch < 1 or not args.stretch_m > 0 or not all(L > 0 for L in args.lengths):
        parser.error("--stretch, --stretch-m and --lengths must be positive")
    try:
        lines = report(args.gt, args.pred, args.times, args.stretch, args.stretch_m, tuple(args.lengths))
    except FlowvoError as error:
        print(f"drive_diagnostic: {error}", file=sys.stderr)
        return 2
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
