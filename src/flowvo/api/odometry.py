"""``flowvo.Odometry``: frames pushed one at a time from Python, poses back as soon as they are final.

``push`` runs the method's stages on each frame in the order the command line's stream runs them
(:mod:`flowvo.drive.stream`: ``prepare``; ``flow``, ``motion``, ``measured``; the window stage; chaining, through
the same functions), with the stream's thread settings (one BLAS thread; OpenCV's as the method asks), so the
poses are those ``flowvo run`` writes for the same frames, to the last digit. A method with a scale window gives
each pose ``latency_frames`` frames after its own frame arrived; ``close`` gives the rest.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from flowvo.api.frames import FrameChecks
from flowvo.api.pose import Pose, StepRecords, make_pose
from flowvo.api.sources import PushedFrames, pushed_drive, run_options
from flowvo.errors import FlowvoError
from flowvo.io.outputs import validate_name
from flowvo.methods import DEFAULT_METHOD

if TYPE_CHECKING:
    from flowvo.api.rerun import RerunLogger
    from flowvo.api.trajectory import Trajectory
    from flowvo.camera import Camera
    from flowvo.drive.run import StartedRun
    from flowvo.methods.base import OdometryStep


class Odometry:
    """Visual odometry on frames handed in one at a time.

    ``camera``: a :class:`flowvo.Camera` in pixels of the frames. ``method``: a name of ``flowvo run --method``
    (flowvo, flowvo-geometry, flowvo-pair, flowvo-ba, cnn, classical). ``model``: the network checkpoint (None:
    the packaged one); ``flow_method``: as ``--flow-method``; ``latency_frames``: the scale window's latency, as
    ``--latency``. ``channel_order``: of colour frames, "bgr" (OpenCV's) or "rgb". ``name``: the drive's name in
    saved files. ``rerun``: a live view (True: spawn the Rerun viewer; a path: record an ``.rrd`` file, written
    when the odometry closes; a :class:`flowvo.api.rerun.RerunLogger` of the caller's, which the caller closes).

    >>> vo = Odometry(camera)                        # doctest: +SKIP
    >>> for time_s, image in frames:                 # doctest: +SKIP
    ...     for pose in vo.push(image, time_s):
    ...         print(pose.time_s, pose.T_world_cam[:3, 3])
    >>> rest = vo.close()                            # doctest: +SKIP
    """

    def __init__(self, camera: Camera, method: str = DEFAULT_METHOD, *, model: str | None = None,
                 flow_method: str | None = None, latency_frames: int | None = None, channel_order: str = "bgr",
                 name: str = "drive", rerun: RerunLogger | bool | str | Path | None = None) -> None:
        if camera is None:
            raise FlowvoError("camera is required: flowvo.Camera(fx, fy, cx, cy) or flowvo.Camera.from_file(path)")
        self.options = run_options(camera, method, model=model, flow_method=flow_method,
                                   latency_frames=latency_frames)
        self.given_camera = camera
        self.name = validate_name(name, "drive")
        self.view, self._owns_view = live_view(rerun)
        self._checks = FrameChecks(channel_order)
        self._started: StartedRun | None = None
        self._records: StepRecords | None = None
        self._previous: tuple[float, Any] | None = None
        self._limits: Any = None
        self._poses: list[Pose] = []
        self._state = "open"
        self._seconds: dict[str, float] = {}
        self._busy_s = 0.0

    @property
    def step(self) -> OdometryStep | None:
        """The method's per-frame step (built at the first frame, when the frames' size is known)."""
        return None if self._started is None else self._started.step

    @property
    def camera(self) -> Camera | None:
        """The camera the method runs with, in pixels of the frames (from the first frame on)."""
        return None if self._started is None else self._started.drive.camera

    @property
    def latency_frames(self) -> int | None:
        """How many frames after its own each pose is final (from the first frame on)."""
        return None if self.step is None else self.step.latency_frames

    @property
    def poses(self) -> list[Pose]:
        """Every pose final so far, in frame order."""
        return list(self._poses)

    @property
    def frames(self) -> int:
        """How many frames were pushed."""
        return self._checks.count

    def push(self, image: np.ndarray, time_s: float) -> list[Pose]:
        """Hand in the next frame: ``image`` (H, W) grey or (H, W, 3) colour, uint8 (see
        :mod:`flowvo.api.frames`), taken at ``time_s`` seconds (after the last frame's). Returns the poses that
        became final with it (oldest first; none while the scale window fills)."""
        self._check_open("push")
        start = time.perf_counter()
        time_s, grey = self._checks.check(image, time_s)  # a refused frame changes nothing
        try:
            if self._started is None:
                self._start(grey.shape)
            with self._stage_limits():
                return self._stages(self._checks.count - 1, time_s, grey, start)
        except BaseException:
            self._state = "failed"
            raise
        finally:
            self._busy_s += time.perf_counter() - start

    def close(self) -> list[Pose]:
        """End the drive: the poses still held by the scale window (oldest first). Pushing after this is an error;
        closing again returns nothing. A live view is finished here (its ``.rrd`` file written)."""
        if self._state == "closed":
            return []
        try:
            self._check_open("close")
            if self._started is None:
                self._state = "closed"
                return []
            start = time.perf_counter()
            with self._stage_limits():
                final = self._chained(self.step.flush(), {})
            self._busy_s += time.perf_counter() - start
            self._state = "closed"
            return final
        finally:
            if self._owns_view:
                self.view.close(ok=self._state == "closed")

    def __enter__(self) -> Odometry:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None, traceback: Any) -> None:
        if kind is not None:
            self._state = "failed"
            if self._owns_view:
                self.view.close(ok=False)
        elif self._state == "open":
            self.close()

    def trajectory(self) -> Trajectory:
        """The poses final so far as a :class:`flowvo.Trajectory`, which saves (KITTI, TUM, MCAP, the run folder of
        ``flowvo run``) and evaluates; after :meth:`close`, the whole drive."""
        from flowvo.api.trajectory import Trajectory
        from flowvo.drive.stream import StreamResult

        if self._started is None or len(self._poses) < 2:
            raise FlowvoError(f"{len(self._poses)} final pose(s) so far: a trajectory needs at least 2")
        result = StreamResult(np.stack([pose.T_world_cam for pose in self._poses]),
                              np.array([pose.time_s for pose in self._poses]), dict(self._seconds), self._busy_s)
        return Trajectory(list(self._poses), self._started, result)

    def _check_open(self, what: str) -> None:
        if self._state == "closed":
            raise FlowvoError(f"{what} after close: this Odometry's drive has ended; start a new flowvo.Odometry")
        if self._state == "failed":
            raise FlowvoError(f"{what} after an earlier frame failed: start a new flowvo.Odometry")

    def _start(self, image_size_hw: tuple[int, int]) -> None:
        """Build the drive's camera and the method's step for frames of ``image_size_hw``, as ``flowvo run`` does."""
        from threadpoolctl import ThreadpoolController

        from flowvo.drive.run import start_run
        from flowvo.methods.stages import STAGES

        self._started = start_run(self.options, pushed_drive(self.options, PushedFrames(self.name, image_size_hw)))
        self._records = StepRecords(self._started.step)
        self._limits = ThreadpoolController()  # after the step loaded its libraries (torch)
        self._seconds = dict.fromkeys(STAGES, 0.0)

    @contextmanager
    def _stage_limits(self) -> Iterator[None]:
        """The stream's thread settings for the step's stages: one BLAS thread, OpenCV's threads as the step asks."""
        import cv2

        threads = cv2.getNumThreads()
        if self.step.opencv_threads is not None:
            cv2.setNumThreads(self.step.opencv_threads)
        try:
            with self._limits.limit(limits=1, user_api="blas"):
                yield
        finally:
            cv2.setNumThreads(threads)

    def _stages(self, index: int, time_s: float, grey: np.ndarray, start: float) -> list[Pose]:
        """One frame through the step's stages, in the stream's order."""
        from flowvo.drive.stream import pair_motion, window_stage

        step = self.step
        prepared = step.complete(step.prepare(grey))
        seconds = {"image_read": time.perf_counter() - start}
        motion = measured = None
        if self._previous is not None:
            previous_time_s, previous = self._previous
            motion, measured, stage_seconds = pair_motion(step, previous, prepared, (previous_time_s, time_s))
            seconds.update(stage_seconds)
        if self.view is not None:
            self.view.frame(index, time_s, prepared, motion, step)
        self._previous = time_s, prepared
        window_start = time.perf_counter()
        final = window_stage(step, time_s, motion, measured)
        seconds["window"] = time.perf_counter() - window_start
        return self._chained(final, seconds)

    def _chained(self, final: list[tuple[float, np.ndarray | None]], seconds: dict[str, float]) -> list[Pose]:
        """Chain the final motions into poses (as the stream chains them) and show them."""
        from flowvo.drive.stream import chained

        start, poses = time.perf_counter(), []
        for time_s, motion in final:
            last = self._poses[-1].T_world_cam if self._poses else None
            record = None if motion is None else self._records.of(time_s)
            pose = make_pose(len(self._poses), time_s, chained(last, motion), motion, record)
            self._poses.append(pose)
            poses.append(pose)
        seconds["chaining"] = seconds.get("chaining", 0.0) + time.perf_counter() - start
        for stage, value in seconds.items():
            self._seconds[stage] = self._seconds.get(stage, 0.0) + value
        if self.view is not None:
            for pose in poses:
                self.view.pose(pose.frame, pose.time_s, pose.T_world_cam, self.step)
        return poses


def live_view(rerun: Any) -> tuple[RerunLogger | None, bool]:
    """A live view from what the caller gave: None or False (none), True (spawn the Rerun viewer), a path (record
    an ``.rrd`` there), or a :class:`flowvo.api.rerun.RerunLogger`; and whether it is ours to close (a logger the
    caller made is the caller's)."""
    if rerun is None or rerun is False:
        return None, False
    from flowvo.api.rerun import RerunLogger

    if isinstance(rerun, RerunLogger):
        return rerun, False
    if rerun is True:
        return RerunLogger(spawn=True), True
    if isinstance(rerun, str | Path):
        return RerunLogger(save=rerun), True
    raise FlowvoError(f"rerun must be True, a path for an .rrd file or a flowvo.api.rerun.RerunLogger, got "
                      f"{type(rerun).__name__}")
