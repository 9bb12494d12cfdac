"""``flowvo.run``: odometry on a whole drive from Python, by the command line's own parts
(:func:`flowvo.drive.run.start_run`, :func:`~flowvo.drive.run.stream_run`): the same poses as ``flowvo run``."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from flowvo.api.odometry import live_view
from flowvo.api.pose import StepRecords, make_pose
from flowvo.api.sources import iterable_source, path_fields, pushed_drive, run_options
from flowvo.errors import FlowvoError
from flowvo.methods import DEFAULT_METHOD

if TYPE_CHECKING:
    from flowvo.api.rerun import RerunLogger
    from flowvo.api.trajectory import Trajectory
    from flowvo.camera import Camera


def run(source: str | Path | Iterable[tuple[float, Any]], camera: Camera | None = None,
        method: str = DEFAULT_METHOD, *, sequence: str | None = None, topic: str | None = None,
        camera_info_topic: str | None = None, model: str | None = None, flow_method: str | None = None,
        latency_frames: int | None = None, max_frames: int | None = None, channel_order: str = "bgr",
        name: str = "drive", overlap: bool = True, rerun: RerunLogger | bool | str | Path | None = None,
        gt: Any = None) -> Trajectory:
    """Odometry on a whole drive; returns its :class:`flowvo.Trajectory`.

    ``source``: a KITTI folder (the dataset root with ``sequence``, or ``ROOT/sequences/NN``), a video file, a ROS
    bag (``.bag``, ``.mcap`` or a ROS 2 bag folder, with ``topic``; ``camera_info_topic`` for its intrinsics), or
    any iterable of ``(time_s, image)`` (seconds, increasing; images as :meth:`flowvo.Odometry.push` takes them;
    ``name`` names the drive, ``gt`` its ground truth if any). ``camera``: a :class:`flowvo.Camera`, over the
    drive's own (KITTI calib.txt, a bag's CameraInfo) as ``--calib`` is; required for an iterable; a video
    without one has its focal length estimated from its motion. ``method`` and the method's options: as
    ``flowvo run``'s. ``max_frames``: stop after that many frames. ``overlap``: read frames in a thread beside
    the flow stage (False: one thread). ``rerun``: a live view, as :class:`flowvo.Odometry`'s (a path's ``.rrd`` is
    written when the drive ends; a logger of the caller's stays open for the caller to close).
    """
    from flowvo.api.trajectory import Trajectory
    from flowvo.drive.options import open_drive
    from flowvo.drive.run import start_run, stream_run

    drive_fields: dict[str, Any] = {"max_frames": max_frames, "overlap_stages": overlap}
    if isinstance(source, str | Path):
        drive_fields.update(path_fields(source, sequence, topic, camera_info_topic))
    elif not isinstance(source, Iterable):
        raise FlowvoError(f"source must be a path (a KITTI folder, a video, a ROS bag) or an iterable of (time_s, "
                          f"image), got {type(source).__name__}")
    elif camera is None:
        raise FlowvoError("frames from an iterable need camera=flowvo.Camera(fx, fy, cx, cy)")
    options = run_options(camera, method, model=model, flow_method=flow_method, latency_frames=latency_frames,
                          **drive_fields)
    if isinstance(source, str | Path):
        drive = open_drive(options)
    else:
        from flowvo.api.evaluation import pose_table

        drive = pushed_drive(options, iterable_source(source, name, channel_order,
                                                      None if gt is None else pose_table(gt, "gt")))
    started = start_run(options, drive)
    view, owned = live_view(rerun)
    try:
        result = stream_run(started, view)
    except BaseException:
        if owned:
            view.close(ok=False)
        raise
    if owned:
        view.close(ok=True)
    records = StepRecords(started.step)
    poses, last = [], None
    for index, (time_s, T_world_cam) in enumerate(zip(result.timestamps_s, result.T_world_cam, strict=True)):
        motion = None if last is None else _step(last, T_world_cam)
        poses.append(make_pose(index, time_s, T_world_cam, motion, None if last is None else records.of(time_s)))
        last = T_world_cam
    return Trajectory(poses, started, result)


def _step(T_world_prev: Any, T_world_cur: Any) -> Any:
    """``T_prev_cur`` from two poses."""
    from flowvo.geometry import invert_se3

    return invert_se3(T_world_prev) @ T_world_cur
