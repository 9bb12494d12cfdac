"""``flowvo.Trajectory``: the poses of a drive run from Python, which saves what ``flowvo run`` writes and evaluates.

A run folder saved from here (:meth:`Trajectory.save`) is written by the command line's own writer
(:func:`flowvo.drive.run.save_run`): the same files, so ``flowvo report`` and the batch index read it alike.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from flowvo.api.evaluation import Evaluation, evaluate
from flowvo.api.pose import Pose
from flowvo.errors import FlowvoError
from flowvo.io.outputs import prepare_output_file
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M
from flowvo.trajectory import Trajectory as PoseTable

if TYPE_CHECKING:
    from flowvo.camera import Camera
    from flowvo.drive.run import StartedRun
    from flowvo.drive.stream import StreamResult
    from flowvo.odometry.scale_window import StepRecord


class Trajectory:
    """The final poses of a drive (:class:`flowvo.Pose`, frame order), with what ran: ``T_world_cam`` (N, 4, 4)
    camera-to-world (world: the first frame's camera frame, x right, y down, z forward, metres), ``times_s`` (N,)
    seconds, ``positions_m`` (N, 3); ``label``/``method``, ``camera`` (the camera it ran with, in pixels of the
    frames), ``steps`` (each step's record, windowed methods) and ``ground_truth`` (a KITTI folder's poses).
    Indexing and iteration give the poses."""

    def __init__(self, poses: list[Pose], started: StartedRun, result: StreamResult) -> None:
        self.poses = poses
        self.started = started
        self.result = result

    def __len__(self) -> int:
        return len(self.poses)

    def __iter__(self) -> Iterator[Pose]:
        return iter(self.poses)

    def __getitem__(self, index: int) -> Pose:
        return self.poses[index]

    @property
    def name(self) -> str:
        """The drive's name: its output files are ``NAME.txt``, ``NAME.tum`` ..."""
        return self.started.drive.source.name

    @property
    def method(self) -> str:
        return self.started.options.method

    @property
    def label(self) -> str:
        """The method and its settings in words."""
        return self.started.step.label

    @property
    def camera(self) -> Camera:
        return self.started.drive.camera

    @property
    def T_world_cam(self) -> np.ndarray:
        return self.result.T_world_cam

    @property
    def times_s(self) -> np.ndarray:
        return self.result.timestamps_s

    @property
    def positions_m(self) -> np.ndarray:
        return self.result.T_world_cam[:, :3, 3].copy()

    @property
    def steps(self) -> list[StepRecord] | None:
        """What became of each step (length, sigma of its log, what measured it), one per pose after the first;
        None without a scale window."""
        records = self.started.step.step_records()
        return None if records is None else records[:max(len(self) - 1, 0)]

    @property
    def ground_truth(self) -> PoseTable | None:
        """The drive's own ground truth (a KITTI folder's ``poses/NN.txt``), else None."""
        return self.started.ground_truth

    def summary(self) -> dict:
        """What the method kept of the run (as ``run.json`` holds it): road planes, scale window, checks."""
        return self.started.step.summary()

    def pose_table(self) -> PoseTable:
        """The poses as a :class:`flowvo.trajectory.Trajectory` (frames 0..N-1)."""
        return PoseTable.from_poses(self.result.T_world_cam)

    def evaluate(self, gt: object = None, *, lengths: tuple[float, ...] | None = None,
                 alignment: str = "none") -> Evaluation:
        """Scores against ``gt`` (a pose file, a trajectory or poses; None: the drive's own ground truth) on
        sub-paths of ``lengths`` metres (default the devkit's 100..800 m), see :func:`flowvo.evaluate`."""
        gt = self.ground_truth if gt is None else gt
        if gt is None:
            raise FlowvoError(f"drive {self.name} has no ground truth of its own: give evaluate(gt=...)")
        return evaluate(gt, self, SEGMENT_LENGTHS_M if lengths is None else lengths, alignment)

    def save(self, folder: str | Path, *, force: bool = False, mcap: bool = False,
             lengths: tuple[float, ...] | None = None, frame_id: str = "odom",
             child_frame_id: str = "camera_optical") -> dict:
        """Write the run folder ``flowvo run`` writes (``NAME.txt`` KITTI poses, ``NAME.tum``, ``timing.json``,
        ``run.json``, ``NAME_steps.csv`` for windowed methods, ``eval_NAME/`` with ground truth on sub-paths of
        ``lengths`` metres, ``NAME.mcap`` with ``mcap``) by the same code; an earlier result there is replaced only
        with ``force``. Returns the summary (run.json)."""
        from flowvo.drive.run import save_run

        records = self.started.step.step_records()
        if records is not None and len(records) != len(self) - 1:
            raise FlowvoError(f"{len(self)} poses but {len(records)} steps measured: save the run folder of pushed "
                              "frames after Odometry.close()")
        options = replace(self.started.options, out=str(folder), force=force, mcap=mcap, frame_id=frame_id,
                          child_frame_id=child_frame_id,
                          lengths_m=self.started.options.lengths_m if lengths is None
                          else tuple(sorted({float(length) for length in lengths})))
        return save_run(replace(self.started, options=options), self.result)

    def save_kitti(self, path: str | Path, *, force: bool = False) -> Path:
        """Write the poses as a KITTI pose file (12 numbers a line, row-major [R | t]); returns its path."""
        from flowvo.kitti.poses import write_kitti_poses

        path = prepare_output_file(path, force, "path")
        write_kitti_poses(path, self.pose_table())
        return path

    def save_tum(self, path: str | Path, *, force: bool = False) -> Path:
        """Write the poses as a TUM trajectory (``time_s tx ty tz qx qy qz qw`` a line); returns its path."""
        from flowvo.kitti.poses import write_tum_trajectory

        path = prepare_output_file(path, force, "path")
        write_tum_trajectory(path, self.pose_table(), self.times_s)
        return path

    def save_mcap(self, path: str | Path, *, force: bool = False, frame_id: str = "odom",
                  child_frame_id: str = "camera_optical") -> Path:
        """Write the poses as an MCAP of ROS 2 messages (nav_msgs/Odometry with covariances for windowed methods,
        /tf, nav_msgs/Path; the ``ros`` extra), as ``flowvo run --mcap`` does; returns its path."""
        from flowvo.odometry.covariance import records_covariances
        from flowvo.ros.extra import require_ros_extra
        from flowvo.ros.odometry_mcap import check_names, check_stamps, write_odometry_mcap

        require_ros_extra("writing MCAP odometry")
        check_names(frame_id, child_frame_id)
        path = prepare_output_file(path, force, "path")
        check_stamps(self.times_s, path)
        records, stamps_ns = self.steps, self.started.drive.source.stamps_ns
        write_odometry_mcap(path, self.times_s, self.T_world_cam, frame_id=frame_id, child_frame_id=child_frame_id,
                            exact_stamps_ns=None if stamps_ns is None else stamps_ns[:len(self)],
                            covariances=None if records is None else records_covariances(self.T_world_cam, records))
        return path

    def __repr__(self) -> str:
        length = float(np.linalg.norm(np.diff(self.positions_m, axis=0), axis=1).sum()) if len(self) > 1 else 0.0
        return f"Trajectory({self.name!r}, {self.method}, {len(self)} poses, {length:.1f} m)"
