"""Stream a frame source through an odometry step as a three-stage pipeline: a reader thread decodes and
prepares frames, a motion thread estimates the flow and the motion of each pair and runs the step's window
stage, and the caller's thread chains the final motions in frame order. OpenCV and torch release the
GIL, so on two cores the stages overlap; the poses are exactly those of running the stages one after
another (which ``overlap=False`` does, in the caller's thread).
"""

from __future__ import annotations

import math
import queue
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any, Protocol

import cv2
import numpy as np
from threadpoolctl import threadpool_limits

from flowvo.errors import FlowvoError
from flowvo.methods.base import OdometryStep
from flowvo.methods.stages import STAGES
from flowvo.progress import progress

_END = object()
_QUEUE_DEPTH = 4


@dataclass
class StreamResult:
    """Poses ``T_world_cam`` (N, 4, 4) (world = first camera), their timestamps (N,) in seconds, summed
    seconds per stage (each measured in its own thread), and the wall-clock seconds of the stream."""

    T_world_cam: np.ndarray
    timestamps_s: np.ndarray
    stage_seconds: dict[str, float] = field(default_factory=dict)
    wall_seconds: float = 0.0

    @property
    def frames(self) -> int:
        return len(self.timestamps_s)


class _Stage:
    """A producer thread that feeds a bounded queue once started; exceptions travel to the consumer; ``cancel``
    stops it."""

    def __init__(self) -> None:
        self.queue: queue.Queue = queue.Queue(maxsize=_QUEUE_DEPTH)
        self.consumer_waiting = False  # the consumer waits for an item now
        self.cancelled = threading.Event()
        self.thread: threading.Thread | None = None

    def start(self, items: Iterator) -> _Stage:
        """Produce ``items`` in a new thread."""
        self.thread = threading.Thread(target=self._run, args=(items,), daemon=True)
        self.thread.start()
        return self

    def _put(self, item: object) -> bool:
        while not self.cancelled.is_set():
            try:
                self.queue.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def _run(self, items: Iterator) -> None:
        try:
            for item in items:
                if not self._put(item):
                    break
        except BaseException as error:  # handed to the consumer, which re-raises it
            self._put(error)
        self._put(_END)

    def __iter__(self) -> Iterator:
        """The items in order; ends at the end of the stream or once the stage is cancelled (a consumer
        thread blocked on an idle queue would otherwise never see the cancellation)."""
        while not self.cancelled.is_set():
            self.consumer_waiting = True
            try:
                item = self.queue.get(timeout=0.1)
            except queue.Empty:
                continue
            finally:
                self.consumer_waiting = False
            if item is _END:
                return
            if isinstance(item, BaseException):
                raise item
            yield item

    def cancel(self) -> None:
        """Stop producing (without waiting; see :func:`_stop`)."""
        self.cancelled.set()


class StreamView(Protocol):
    """What watches a stream as it runs (a live view, :mod:`flowvo.api.rerun`): ``frame`` after each frame's motion
    (in the motion thread, right after the step's ``motion``, so the step's state is that frame's; ``motion``
    None for the first frame), ``pose`` for each final pose (in the caller's thread, frame order)."""

    def frame(self, index: int, time_s: float, prepared: Any, motion: np.ndarray | None,
              step: OdometryStep) -> None: ...

    def pose(self, index: int, time_s: float, T_world_cam: np.ndarray, step: OdometryStep) -> None: ...


def check_frame_time(index: int, time_s: float, last_time_s: float | None) -> None:
    """Refuse frame ``index``'s time (seconds) unless it is finite and after the last frame's."""
    if not math.isfinite(time_s):
        raise FlowvoError(f"frame {index} has time {time_s} s: timestamps must be finite seconds")
    if last_time_s is not None and not time_s > last_time_s:
        raise FlowvoError(f"timestamps must increase: frame {index} at {time_s:.6f} s follows "
                          f"{last_time_s:.6f} s")


def pair_motion(step: OdometryStep, previous: Any, prepared: Any, times_s: tuple[float, float]
                ) -> tuple[np.ndarray, Any, dict[str, float]]:
    """The step's stages on one pair of prepared frames, in order (``flow``, ``motion``, ``measured``): the
    motion ``T_prev_cur``, what the window stage needs of it, and the seconds of the flow and motion stages."""
    start = time.perf_counter()
    flow = step.flow(previous, prepared)
    middle = time.perf_counter()
    motion = step.motion(times_s, previous, flow)
    measured = step.measured()
    return motion, measured, {"flow": middle - start, step.motion_stage: time.perf_counter() - middle}


def window_stage(step: OdometryStep, time_s: float, motion: np.ndarray | None, measured: Any
                 ) -> list[tuple[float, np.ndarray | None]]:
    """The step's window stage for the frame at ``time_s``: the (time, motion) pairs now final (motion None: the
    first frame, final at once)."""
    return [(time_s, None)] if motion is None else step.refine(time_s, motion, measured)


def chained(last_T_world_cam: np.ndarray | None, motion: np.ndarray | None) -> np.ndarray:
    """The next pose ``T_world_cur = T_world_prev @ T_prev_cur`` (the identity for the first frame)."""
    return np.eye(4) if motion is None else last_T_world_cam @ motion


def _stop(*stages: _Stage) -> None:
    """Cancel every stage first, then wait for each thread, so that no OpenCV or torch call is still
    running in a thread when the interpreter exits (a C++ runtime then aborts the process: exit 134,
    "terminate called without an active exception", seen after Ctrl-C)."""
    for stage in stages:
        stage.cancel()
    for stage in stages:
        stage.thread.join()


def _read(frames: Iterator[tuple[float, np.ndarray]], step: OdometryStep, max_frames: int | None,
          motion_busy: Callable[[], bool] = lambda: False) -> Iterator[tuple[float, Any, float]]:
    """Yield ``(time_s, prepared frame, seconds reading and preparing it)``, timestamps checked; each frame
    completed (:meth:`OdometryStep.complete`) here when ``motion_busy()`` (the motion thread is not waiting for a
    frame), else left for the motion thread, so that neither waits for the other as long."""
    iterator, count, last_time_s = iter(frames), 0, None
    while max_frames is None or count < max_frames:
        start = time.perf_counter()
        item = next(iterator, None)
        if item is None:
            return
        time_s, image = item
        check_frame_time(count, time_s, last_time_s)
        prepared = step.prepare(image)
        if motion_busy():
            prepared = step.complete(prepared)
        yield time_s, prepared, time.perf_counter() - start
        count, last_time_s = count + 1, time_s


def _motions(prepared_frames: Iterable[tuple[float, Any, float]], step: OdometryStep,
             view: StreamView | None = None) -> Iterator[tuple[float, np.ndarray | None, Any, dict[str, float]]]:
    """Yield ``(time_s, motion from the previous frame (None for the first), what the window stage needs
    of it, seconds per stage)``."""
    previous, previous_time_s = None, None
    for index, (time_s, prepared, read_s) in enumerate(prepared_frames):
        start = time.perf_counter()
        prepared = step.complete(prepared)  # where the reader thread left it: its share of the motion stage's work
        seconds, motion, measured = {"image_read": read_s, step.motion_stage: time.perf_counter() - start}, None, None
        if previous is not None:
            motion, measured, stage_seconds = pair_motion(step, previous, prepared, (previous_time_s, time_s))
            seconds[step.motion_stage] += stage_seconds.pop(step.motion_stage)
            seconds.update(stage_seconds)
        if view is not None:
            view.frame(index, time_s, prepared, motion, step)
        yield time_s, motion, measured, seconds
        previous, previous_time_s = prepared, time_s


def _windowed(motions: Iterable[tuple[float, np.ndarray | None, Any, dict[str, float]]],
              step: OdometryStep) -> Iterator[tuple[float, np.ndarray | None, dict[str, float]]]:
    """The step's window stage over the motions (in the motion thread; without overlap, the caller's):
    ``(time_s, final motion, seconds per stage)`` in frame order, each motion ``step.latency_frames`` late;
    the seconds of frames whose motion is not final yet come with the next one yielded."""
    pending: dict[str, float] = {}
    for time_s, motion, measured, seconds in motions:
        for stage, value in seconds.items():
            pending[stage] = pending.get(stage, 0.0) + value
        start = time.perf_counter()
        final = window_stage(step, time_s, motion, measured)
        pending["window"] = pending.get("window", 0.0) + time.perf_counter() - start
        for final_time_s, final_motion in final:
            yield final_time_s, final_motion, pending
            pending = {}
    for final_time_s, final_motion in step.flush():
        yield final_time_s, final_motion, pending
        pending = {}


def stream_odometry(frames: Iterator[tuple[float, np.ndarray]], step: OdometryStep, total: int | None = None,
                    max_frames: int | None = None, label: str = "odometry", overlap: bool = True,
                    view: StreamView | None = None) -> StreamResult:
    """Run ``step`` over ``frames`` ((time_s, grey image), in order) and chain the motions.

    ``overlap``: read and prepare frames in one thread and estimate motions in another, beside the caller's
    (False: all in the caller's thread, for a process that should use one core, as a batch worker). ``view``:
    shown each frame and final pose (:class:`StreamView`). One frame at a time from the caller's code:
    :class:`flowvo.api.odometry.Odometry`, the same stages in the same order.
    """
    # One BLAS thread: OpenBLAS's idle threads spin after each small matrix product and slowed the flow
    # stage 1.5x (56 -> 85 frames/s on real KITTI frames). OpenCV's pool as the step asks: a step whose
    # stages balance across the two threads runs faster with one OpenCV thread per call (default method:
    # 99 -> 101-102 frames/s), one dominated by a single big flow call runs slower (cnn 76 -> 64). Without
    # overlap, OpenCV keeps the caller's setting.
    opencv_threads = cv2.getNumThreads()
    if step.opencv_threads is not None and overlap:
        cv2.setNumThreads(step.opencv_threads)
    try:
        with threadpool_limits(limits=1, user_api="blas"):
            wall_start = time.perf_counter()
            if not overlap:
                return _chain(_windowed(_motions(_read(frames, step, max_frames), step, view), step), [], total,
                              label, wall_start, view, step)
            reader = _Stage()
            reader.start(_read(frames, step, max_frames, lambda: not reader.consumer_waiting))  # a frame's
            # completion left to the motion thread while it waits for frames (on clip 07 it waited 1.2 ms a frame
            # for frames with every fit in the reader, 0.3 ms now): 11.6-12.0 ms a frame instead of 12.0-12.3 in
            # three paired bench runs, the same in two later ones on a drifting machine
            motions = _Stage().start(_windowed(_motions(reader, step, view), step))  # the window stage in the motion
            # thread: in the caller's thread, a third one running Python beside these two, the default method
            # streamed at 0.32 of decoding instead of 0.345 (clip 07, median of six paired bench runs each)
            return _chain(motions, [reader, motions], total, label, wall_start, view, step)
    finally:
        cv2.setNumThreads(opencv_threads)


def _chain(motions: Iterable[tuple[float, np.ndarray | None, dict[str, float]]], stages: list[_Stage],
           total: int | None, label: str, wall_start: float, view: StreamView | None = None,
           step: OdometryStep | None = None) -> StreamResult:
    """Chain the motions into poses in frame order (the caller's thread); the ``stages`` are stopped after."""
    seconds = dict.fromkeys(STAGES, 0.0)
    poses: list[np.ndarray] = []
    times: list[float] = []
    try:
        for time_s, motion, stage_seconds in progress(motions, label, total, "frame"):
            start = time.perf_counter()
            poses.append(chained(poses[-1] if poses else None, motion))
            seconds["chaining"] += time.perf_counter() - start
            if view is not None:
                view.pose(len(poses) - 1, time_s, poses[-1], step)
            for stage, value in stage_seconds.items():
                seconds[stage] += value
            times.append(time_s)
    finally:
        _stop(*stages)
    if not poses:
        raise FlowvoError("the drive has no frames")
    return StreamResult(np.stack(poses), np.asarray(times), seconds, time.perf_counter() - wall_start)


def timing_report(result: StreamResult) -> dict:
    """Seconds per frame by stage (stages overlap: image reading runs in its own thread), and the
    wall-clock total per frame and frames per second of the whole stream."""
    frames = max(result.frames - 1, 1)
    per_frame = {stage: seconds / frames for stage, seconds in result.stage_seconds.items()}
    per_frame["total"] = result.wall_seconds / frames
    return {"seconds_per_frame": per_frame, "frames": result.frames,
            "frames_per_second": 1.0 / per_frame["total"] if per_frame["total"] > 0 else None,
            "note": "image_read runs in a reader thread, overlapped with the other stages; total is wall-clock"}
