"""Stream a frame source through an odometry step: frames are decoded in a reader thread (OpenCV releases
the GIL) while the step works on the previous pair, and motions are chained into camera-to-world poses.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from flowvo.errors import FlowvoError
from flowvo.odometry_step import OdometryStep
from flowvo.progress import progress

STAGES = ("image_read", "flow", "network", "geometry", "chaining")
_END = object()


@dataclass
class StreamResult:
    """Poses ``T_world_cam`` (N, 4, 4) (world = first camera), their timestamps (N,) in seconds, summed
    seconds per stage, and the wall-clock seconds of the whole stream."""

    T_world_cam: np.ndarray
    timestamps_s: np.ndarray
    stage_seconds: dict[str, float] = field(default_factory=dict)
    wall_seconds: float = 0.0

    @property
    def frames(self) -> int:
        return len(self.timestamps_s)


def _prefetch(frames: Iterator[tuple[float, np.ndarray]], depth: int = 4
              ) -> Iterator[tuple[float, np.ndarray, float]]:
    """Yield (time_s, image, seconds spent decoding it) with decoding running ahead in a thread."""
    buffer: queue.Queue = queue.Queue(maxsize=depth)

    def read() -> None:
        try:
            iterator = iter(frames)
            while True:
                start = time.perf_counter()
                item = next(iterator, _END)
                if item is _END:
                    break
                buffer.put((*item, time.perf_counter() - start))
        except BaseException as error:  # handed to the consumer, which re-raises it
            buffer.put(error)
        buffer.put(_END)

    thread = threading.Thread(target=read, daemon=True)
    thread.start()
    while (item := buffer.get()) is not _END:
        if isinstance(item, BaseException):
            raise item
        yield item


def stream_odometry(frames: Iterator[tuple[float, np.ndarray]], step: OdometryStep, total: int | None = None,
                    max_frames: int | None = None, label: str = "odometry") -> StreamResult:
    """Run ``step`` over ``frames`` ((time_s, grey image) in order) and chain the motions."""
    seconds = dict.fromkeys(STAGES, 0.0)
    poses: list[np.ndarray] = []
    times: list[float] = []
    wall_start = time.perf_counter()
    items = _prefetch(frames)
    for time_s, image, read_s in progress(items, label, total, "frame"):
        seconds["image_read"] += read_s
        if times and time_s <= times[-1]:
            raise FlowvoError(f"timestamps must increase: frame {len(times)} at {time_s:.6f} s follows "
                              f"{times[-1]:.6f} s")
        if not poses:
            step.start(time_s, image)
            poses.append(np.eye(4))
        else:
            motion, stage_seconds = step.push(time_s, image)
            start = time.perf_counter()
            poses.append(poses[-1] @ motion)
            seconds["chaining"] += time.perf_counter() - start
            for stage, value in stage_seconds.items():
                seconds[stage] += value
        times.append(time_s)
        if max_frames is not None and len(times) >= max_frames:
            break
    if not poses:
        raise FlowvoError("no frames to run on")
    return StreamResult(np.stack(poses), np.asarray(times), seconds, time.perf_counter() - wall_start)
