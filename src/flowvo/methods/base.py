"""The per-frame odometry step every method implements, and the working frames they share.

A step has three stages that a stream can run in separate threads (OpenCV and torch release the GIL):
``prepare(image)`` turns a decoded grey frame into the step's working frame (resize), ``complete(prepared)`` does
the rest of its preparing, which either thread may do with the same result (the reader's unless the motion thread
waits for a frame, else the motion thread's, before the flow), ``flow(previous,
current)`` estimates what moved between two working frames (stateless), and ``motion(times_s, previous,
flow)`` turns that into the camera motion ``T_prev_cur`` (4x4: the current camera's pose in the previous
camera's frame, metres), called once per step in frame order, so it may keep history (past flows for a
stacked network, the speed prior). Every caller (run, bench, the demo; KITTI folders, video, bags)
therefore runs exactly the same inference. ``measured()``, called right after ``motion`` in the same
thread, returns what the window stage needs of that step; ``refine(time_s, motion, measured)``, the
window stage (a stream runs it in the motion thread after each step's ``motion``, in frame order),
returns the motions that are
final, ``latency_frames`` steps late (at once for the methods without a window, :class:`NoWindow`);
``flush()`` returns the rest at the end of the drive; ``step_records()``, what became of each final step
(the windowed methods: :class:`flowvo.odometry.scale_window.StepRecord`; None for the others).
``summary()`` reports what the method wants kept in run.json.
"""

from __future__ import annotations

from typing import Any, Protocol

import cv2
import numpy as np

from flowvo.camera import Camera, undistortion_maps

MIN_FLOW_SIDE_PX = 32  # OpenCV's DIS crashes the process on fields smaller than this a side
REFERENCE_WIDTH_PX = 620  # pixel thresholds are tuned at this working width and scale with it


class OdometryStep(Protocol):
    """Streaming motion estimator in three stages (see the module docstring)."""

    label: str
    motion_stage: str  # the stage name ``motion`` is timed as: "geometry" or "network"
    opencv_threads: int | None  # OpenCV threads per call while streaming (None: OpenCV's default)

    def prepare(self, image: np.ndarray) -> Any: ...

    def complete(self, prepared: Any) -> Any: ...

    def flow(self, previous: Any, current: Any) -> Any: ...

    def motion(self, times_s: tuple[float, float], previous: Any, flow: Any) -> np.ndarray: ...

    latency_frames: int  # how many steps late ``refine`` returns a motion

    def measured(self) -> Any: ...

    def refine(self, time_s: float, motion: np.ndarray, measured: Any) -> list[tuple[float, np.ndarray]]: ...

    def flush(self) -> list[tuple[float, np.ndarray]]: ...

    def step_records(self) -> list | None: ...

    def summary(self) -> dict: ...


class NoWindow:
    """The window stage of a method without one: every motion is final at once."""

    latency_frames = 0

    def measured(self) -> None:
        """Nothing: the window stage passes motions on."""
        return None

    def refine(self, time_s: float, motion: np.ndarray, measured: None) -> list[tuple[float, np.ndarray]]:
        """The motion of the step ending at ``time_s``, unchanged."""
        return [(time_s, motion)]

    def flush(self) -> list[tuple[float, np.ndarray]]:
        """Nothing is held back."""
        return []

    def step_records(self) -> None:
        """No window, no record of how each step was measured."""
        return None


class WorkingFrames:
    """Frames resized to ``working_width`` px (never enlarged), the camera scaled with them; with
    ``undistort`` also remapped to the ideal pinhole image (for methods that read whole frames: the
    network), else the distortion is left to the method (undistorting points is cheaper)."""

    def __init__(self, camera: Camera, image_size_hw: tuple[int, int], working_width: int,
                 undistort: bool = False) -> None:
        h, w = image_size_hw
        scale = min(1.0, working_width / w)
        self.working_hw = (int(round(h * scale)), int(round(w * scale)))
        self.camera = camera.scaled(self.working_hw[1] / w, self.working_hw[0] / h)
        self.intrinsics = self.camera.intrinsics
        self.K = self.intrinsics.K
        self.resize = self.working_hw != (h, w)
        self.maps = undistortion_maps(self.working_hw, self.K, camera.distortion) \
            if undistort and not camera.distortion.is_none else None

    def prepare(self, image: np.ndarray) -> np.ndarray:
        """The frame at the working resolution (area interpolation), undistorted when asked."""
        working = cv2.resize(image, self.working_hw[::-1], interpolation=cv2.INTER_AREA) if self.resize \
            else np.ascontiguousarray(image)
        return self.undistort(working)

    def complete(self, prepared: Any) -> Any:
        """The prepared frame: nothing is left to do."""
        return prepared

    def undistort(self, working: np.ndarray) -> np.ndarray:
        """A working frame remapped to the ideal pinhole image (unchanged without undistortion maps)."""
        if self.maps is None:
            return working
        return cv2.remap(working, *self.maps, interpolation=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

    def summary(self) -> dict:
        """Nothing beyond the common run summary."""
        return {}
