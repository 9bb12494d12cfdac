"""Where a run's error comes from, against ground truth: its path length over the true one per stretch of the
drive (by frames or by distance) beside the stretch's speed and turn, and the error split, the KITTI metric of
the run with one part of each step replaced by the truth.

Poses are ``T_world_cam`` (N, 4, 4), camera-to-world, KITTI's camera frame (x right, y down, z forward), metres;
the truth and the run hold the same N frames. A step is the motion ``T_prev_cur`` between consecutive frames
(:func:`flowvo.geometry.relative_motions`), its length the norm of its translation (m). Turns are heading
changes about the camera's y axis (:func:`flowvo.geometry.yaw_rad`), degrees, positive to the right. Times in
seconds (KITTI's 0.1 s a frame where none are given).

The split: the run's rotations and directions of travel with the true step lengths (what its rotations cost),
and the true rotations and directions with the run's step lengths (what its lengths cost). A path whose lengths
are all 2 % long has path ratio 1.02 in every stretch and no error left with the true lengths.

The direction offset: the run's direction of travel against the truth's, each step's in the camera frame of its
start (azimuth positive to the right, elevation positive up, degrees), the medians over the steps. A constant offset
is what a truth given in a camera frame turned against the images' own (a GNSS/INS boresight, an IMU-to-camera
calibration, a principal point off) puts on every step; the split also scores the run with it removed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flowvo.geometry import relative_motions, so3_exp, wrap_angle_rad, yaw_rad
from flowvo.metrics.clock_offset import clock_offset, with_clock_offset_removed
from flowvo.metrics.kitti_odometry import FRAME_PERIOD_S, SEGMENT_LENGTHS_M, sequence_segment_errors, summarize
from flowvo.metrics.rotation_bias import (
    rotation_bias,
    step_rotation_vectors,
    with_rotation_bias_removed,
    with_yaw_scaled,
)
from flowvo.trajectory import Trajectory


@dataclass(frozen=True)
class Stretch:
    """Frames ``first_frame`` to ``last_frame`` (both included) of a drive: the true and the estimated path
    length over its steps (m), the true mean speed (m/s) and the true heading change (degrees, positive to the
    right)."""

    first_frame: int
    last_frame: int
    true_length_m: float
    estimated_length_m: float
    mean_speed_mps: float
    turn_deg: float

    @property
    def path_ratio(self) -> float:
        """The estimated path length over the true one (NaN where the truth stood still throughout)."""
        return self.estimated_length_m / self.true_length_m if self.true_length_m > 0 else float("nan")


MIN_DIRECTION_STEP_M = 0.3  # shorter steps (of the run or the truth) give no direction: a real truth's direction of a
# step of a few centimetres is its own noise


@dataclass(frozen=True)
class DirectionOffset:
    """The run's direction of travel against the truth's (module docstring): medians over ``steps`` steps of the
    azimuth (degrees, positive to the right) and elevation (degrees, positive up) differences."""

    azimuth_deg: float
    elevation_deg: float
    steps: int

    def turn(self) -> np.ndarray:
        """The rotation (3, 3, camera frame) that takes the forward axis to this azimuth and elevation: raised about
        the x axis, then turned about the y axis."""
        return turn_rotation(self.azimuth_deg, self.elevation_deg)


def turn_rotation(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """``R_y(azimuth) R_x(elevation)`` (3, 3): the camera's forward axis (0, 0, 1) turned to the given azimuth
    (positive to the right, towards +x) and elevation (positive up, towards -y), degrees."""
    turn_y = so3_exp(np.array([0.0, np.radians(azimuth_deg), 0.0]))  # about the down axis: forward turns right
    raise_x = so3_exp(np.array([np.radians(elevation_deg), 0.0, 0.0]))  # about the right axis: forward turns up
    return turn_y @ raise_x


def _azimuth_elevation_rad(directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth (towards +x) and elevation (towards -y), radians, of camera-frame vectors (N, 3)."""
    x, y, z = directions.T
    return np.arctan2(x, z), np.arctan2(-y, np.hypot(x, z))


def direction_offset(T_gt: np.ndarray, T_pred: np.ndarray, min_step_m: float = MIN_DIRECTION_STEP_M
                     ) -> DirectionOffset:
    """The run's direction of travel against the truth's over the steps where both moved at least ``min_step_m``
    (NaN where none did)."""
    _check_pair(T_gt, T_pred)
    true_steps, run_steps = relative_motions(T_gt)[:, :3, 3], relative_motions(T_pred)[:, :3, 3]
    moving = (np.linalg.norm(true_steps, axis=1) >= min_step_m) & (np.linalg.norm(run_steps, axis=1) >= min_step_m)
    if not moving.any():
        return DirectionOffset(float("nan"), float("nan"), 0)
    (true_azimuth, true_elevation), (run_azimuth, run_elevation) = (
        _azimuth_elevation_rad(true_steps[moving]), _azimuth_elevation_rad(run_steps[moving]))
    return DirectionOffset(float(np.degrees(np.median(wrap_angle_rad(run_azimuth - true_azimuth)))),
                           float(np.degrees(np.median(run_elevation - true_elevation))), int(moving.sum()))


def with_direction_turned(T_pred: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """The run (N, 4, 4) with each step's direction of travel turned by ``turn`` (3, 3) in the camera frame of the
    step's start, its orientations and step lengths its own, from its first pose."""
    steps_cam = relative_motions(T_pred)[:, :3, 3]  # each step in the camera frame of its start
    turned_world = np.einsum("nij,nj->ni", T_pred[:-1, :3, :3], steps_cam @ turn.T)
    lengths_m = step_lengths_m(T_pred)
    directions = np.divide(turned_world, lengths_m[:, None], out=np.zeros_like(turned_world),
                           where=lengths_m[:, None] > 0)
    return _chained(T_pred, directions, lengths_m)


def _check_pair(T_gt: np.ndarray, T_pred: np.ndarray) -> None:
    if T_gt.ndim != 3 or T_gt.shape[1:] != (4, 4) or T_gt.shape != T_pred.shape:
        raise ValueError(f"the truth and the run must both be (N, 4, 4) poses of the same frames, got {T_gt.shape} "
                         f"and {T_pred.shape}")
    if len(T_gt) < 2:
        raise ValueError("a drive needs at least two frames")


def step_lengths_m(T_world_cam: np.ndarray) -> np.ndarray:
    """The length (m) of each step (N-1,) of poses (N, 4, 4): the distance between consecutive camera centres."""
    return np.linalg.norm(np.diff(T_world_cam[:, :3, 3], axis=0), axis=1)


def _world_steps(T_world_cam: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Unit directions (N-1, 3) of the steps of ``T_world_cam`` (N, 4, 4) in its world frame; a step of zero
    length takes the direction of the same step of ``fallback`` (N, 4, 4; its world frame), carried into this
    one through the two poses at the step's start (zero where that step stands still too)."""
    directions = np.zeros((len(T_world_cam) - 1, 3))
    for poses, into in ((fallback, T_world_cam[:-1, :3, :3] @ np.swapaxes(fallback[:-1, :3, :3], 1, 2)),
                        (T_world_cam, None)):  # the poses' own directions win where they have one
        steps = np.diff(poses[:, :3, 3], axis=0)
        lengths = np.linalg.norm(steps, axis=1)
        moving = lengths > 0
        unit = steps[moving] / lengths[moving, None]
        directions[moving] = unit if into is None else np.einsum("nij,nj->ni", into[moving], unit)
    return directions


def _chained(T_world_cam: np.ndarray, directions: np.ndarray, lengths_m: np.ndarray) -> np.ndarray:
    """Poses with the orientations of ``T_world_cam`` (N, 4, 4) and positions from its first one along the world
    directions (N-1, 3) by ``lengths_m`` (N-1,). Built in the world frame, not by chaining relative motions:
    KITTI's poses are orthonormal to about 4e-7 only, and motions chained over hundreds of steps shrink their
    rotations enough for the devkit's trace to read a few thousandths of a degree per metre."""
    poses = T_world_cam.copy()
    poses[1:, :3, 3] = T_world_cam[0, :3, 3] + np.cumsum(directions * lengths_m[:, None], axis=0)
    return poses


def with_true_lengths(T_gt: np.ndarray, T_pred: np.ndarray) -> np.ndarray:
    """The run (N, 4, 4) with each step's rotation and direction of travel its own and its length the truth's,
    from the run's first pose. A step the run stood still on (zero length) takes the true direction (in the
    camera frame of the step's start)."""
    _check_pair(T_gt, T_pred)
    return _chained(T_pred, _world_steps(T_pred, T_gt), step_lengths_m(T_gt))


def with_true_rotations(T_gt: np.ndarray, T_pred: np.ndarray) -> np.ndarray:
    """The true poses' orientations and directions of travel with the run's step lengths (N, 4, 4), from the
    truth's first pose. A step the truth stood still on takes the run's direction."""
    _check_pair(T_gt, T_pred)
    return _chained(T_gt, _world_steps(T_gt, T_pred), step_lengths_m(T_pred))


def with_lengths_scaled(T_pred: np.ndarray, factor: float) -> np.ndarray:
    """The run (N, 4, 4) with every step's length times ``factor`` (its orientations and directions unchanged):
    its positions scaled about its first one."""
    poses = T_pred.copy()
    poses[:, :3, 3] = T_pred[0, :3, 3] + factor * (T_pred[:, :3, 3] - T_pred[0, :3, 3])
    return poses


def on_true_path(T_gt: np.ndarray, T_pred: np.ndarray) -> np.ndarray:
    """The truth's positions (N, 4, 4) with the run's orientations, chained from the truth's first by the run's step
    rotations: two runs put on it differ in their rotations alone, their lengths and directions of travel set aside."""
    _check_pair(T_gt, T_pred)
    step_rotations = so3_exp(step_rotation_vectors(T_pred))  # orthonormal (see with_step_rotations_changed: a KITTI
    # file's rotations, chained, would shrink)
    poses = T_gt.copy()
    orientation = T_gt[0, :3, :3]
    for k, step in enumerate(step_rotations):
        orientation = orientation @ step
        poses[k + 1, :3, :3] = orientation
    return poses


def path_ratio(T_gt: np.ndarray, T_pred: np.ndarray) -> float:
    """The run's whole path length over the true one (the sums of the step lengths)."""
    _check_pair(T_gt, T_pred)
    return float(step_lengths_m(T_pred).sum() / step_lengths_m(T_gt).sum())


def frame_bounds(n_frames: int, frames: int) -> list[tuple[int, int]]:
    """Stretches of ``frames`` steps each over a drive of ``n_frames`` frames, as (first, last) frames: (0,
    frames), (frames, 2 frames), ...; the last one holds the steps that remain."""
    if frames < 1:
        raise ValueError(f"a stretch holds at least one step, got {frames}")
    starts = list(range(0, n_frames - 1, frames))
    return [(first, min(first + frames, n_frames - 1)) for first in starts]


def distance_bounds(T_gt: np.ndarray, length_m: float) -> list[tuple[int, int]]:
    """Stretches of about ``length_m`` of true path each, as (first, last) frames: each ends at the first frame
    whose true path distance from the drive's start reaches the next multiple of ``length_m``; the last one
    holds the path that remains."""
    if not length_m > 0:
        raise ValueError(f"a stretch's length must be positive, got {length_m}")
    distance_m = np.concatenate([[0.0], np.cumsum(step_lengths_m(T_gt))])
    ends = [int(np.argmax(distance_m >= k * length_m)) for k in range(1, int(distance_m[-1] // length_m) + 1)]
    bounds = [0, *ends] + ([len(T_gt) - 1] if not ends or ends[-1] < len(T_gt) - 1 else [])
    return [(first, last) for first, last in zip(bounds[:-1], bounds[1:], strict=True) if last > first]


def stretches(T_gt: np.ndarray, T_pred: np.ndarray, bounds: list[tuple[int, int]],
              times_s: np.ndarray | None = None) -> list[Stretch]:
    """Each stretch of ``bounds`` ((first, last) frames, :func:`frame_bounds` or :func:`distance_bounds`) with
    its true and estimated path length, true mean speed and true turn; ``times_s`` (N,) the frames' times in
    seconds (None: KITTI's 0.1 s a frame)."""
    _check_pair(T_gt, T_pred)
    times_s = FRAME_PERIOD_S * np.arange(len(T_gt)) if times_s is None else np.asarray(times_s, dtype=float)
    if times_s.shape != (len(T_gt),):
        raise ValueError(f"one time per frame expected: {len(T_gt)} frames, {times_s.shape} times")
    true_m, run_m, heading = step_lengths_m(T_gt), step_lengths_m(T_pred), yaw_rad(T_gt)
    rows = []
    for first, last in bounds:
        true_length = float(true_m[first:last].sum())
        rows.append(Stretch(first, last, true_length, float(run_m[first:last].sum()),
                            true_length / float(times_s[last] - times_s[first]),
                            float(np.degrees(wrap_angle_rad(heading[last] - heading[first])))))
    return rows


def kitti_errors(T_gt: np.ndarray, T_pred: np.ndarray, lengths_m: tuple[float, ...] = SEGMENT_LENGTHS_M) -> dict:
    """The KITTI metric (:func:`flowvo.metrics.kitti_odometry.summarize`) of poses of the same frames on
    sub-paths of ``lengths_m``; raises ValueError when the drive is shorter than all of them."""
    _check_pair(T_gt, T_pred)
    errors = sequence_segment_errors(Trajectory.from_poses(T_gt), Trajectory.from_poses(T_pred), lengths_m)
    return summarize(errors, lengths_m)


def error_split(T_gt: np.ndarray, T_pred: np.ndarray, lengths_m: tuple[float, ...] = SEGMENT_LENGTHS_M
                ) -> dict[str, dict]:
    """The KITTI metric (``t_err_percent``, ``r_err_deg_per_m``, ``segments``) and the path ratio of: the run
    (``run``), its rotations and directions with the true step lengths (``true_lengths``), the true rotations
    and directions with its step lengths (``true_rotations``), its lengths all divided by its whole path
    ratio (``one_factor``: what is left once the lengths' overall bias is removed), and the run and its
    ``true_lengths`` variant with their :func:`direction_offset` turned back (``offset_removed``,
    ``true_lengths_offset_removed``: what is left once a constant offset of the directions is removed), and the run
    with its mean rotation error per step taken off every step (``rotation_bias_removed``,
    :mod:`flowvo.metrics.rotation_bias`: what is left once the rotations' bias is removed), and the run with every
    step's yaw divided by the slope of its yaw against the truth's (``yaw_slope_removed``: what is left once its turns
    read at their true size; the run as it is where no slope is read), and the run read at the truth's times
    (``clock_offset_removed``, :mod:`flowvo.metrics.clock_offset`: what is left once the truth's clock against the
    images' is taken out; the run as it is where no offset is read)."""
    ratio = path_ratio(T_gt, T_pred)
    bias = rotation_bias(T_gt, T_pred)
    offset = direction_offset(T_gt, T_pred)
    unturned = T_pred if offset.steps == 0 else with_direction_turned(T_pred, offset.turn().T)
    variants = {"run": T_pred, "true_lengths": with_true_lengths(T_gt, T_pred),
                "true_rotations": with_true_rotations(T_gt, T_pred),
                "one_factor": with_lengths_scaled(T_pred, 1.0 / ratio),
                "offset_removed": unturned, "true_lengths_offset_removed": with_true_lengths(T_gt, unturned),
                "rotation_bias_removed": with_rotation_bias_removed(T_gt, T_pred, bias.mean_error_rad),
                "yaw_slope_removed": with_yaw_scaled(T_pred, 1.0 / bias.yaw_slope) if bias.yaw_slope > 0 else T_pred,
                "clock_offset_removed": with_clock_offset_removed(T_pred, clock_offset(T_gt, T_pred))}
    split = {}
    for name, poses in variants.items():
        metric = kitti_errors(T_gt, poses, lengths_m)
        split[name] = {"t_err_percent": metric["t_err_percent"], "r_err_deg_per_m": metric["r_err_deg_per_m"],
                       "segments": metric["segments"], "path_ratio": path_ratio(T_gt, poses)}
    return split
