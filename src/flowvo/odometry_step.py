"""The one per-frame odometry step, shared by ``run`` (KITTI folders, video, bags), ``bench`` and the demo.

A step has three stages that a stream can run in separate threads (OpenCV and torch release the GIL):
``prepare(image)`` turns a decoded grey frame into the step's working frame (resize), ``flow(previous,
current)`` estimates what moved between two working frames (stateless), and ``motion(times_s, previous,
flow)`` turns that into the camera motion ``T_prev_cur`` (4x4: the current camera's pose in the previous
camera's frame, metres), called once per step in frame order, so it may keep history (past flows for a
stacked network, the speed prior). Every caller therefore runs exactly the same inference.

Methods:
- ``flowvo`` (default): rotation and translation direction from an essential matrix fitted to textured
  points tracked over the whole frame (pyramidal Lucas-Kanade); metric step length from the road plane,
  triangulated from the dense DIS flow of the road ahead at the working resolution, at the known camera
  height, filtered by a smooth-speed prior; standstill below half a pixel of motion. No ground truth
  enters it.
- ``cnn``: the thesis network (distance and heading change regressed from the flow field).
- ``classical``: KLT corners + essential matrix, scale from the camera height (sparse baseline).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any, Protocol

import cv2
import numpy as np
import torch

from flowvo.camera import CameraIntrinsics
from flowvo.classical_vo import CAMERA_HEIGHT_M, ClassicalTracker
from flowvo.errors import FlowvoError
from flowvo.flow.registry import create_estimator
from flowvo.flow_geometry import (
    essential_motion,
    follow_flow,
    road_crop,
    road_grid,
    road_step_length_m,
    se3_next_prev,
    textured_points,
    track_points,
)
from flowvo.geometry import chain_planar, chain_se3, invert_se3, se3_from_targets
from flowvo.model.data import Normalization, resize_flow
from flowvo.model.deployable import DeployableOdometry
from flowvo.model.network import OdometryNet
from flowvo.speed_prior import SpeedPrior

STILL_FLOW_PX_AT_620 = 0.5
DEFAULT_FLOW_METHOD = "dis-medium-fine"
DEFAULT_WORKING_WIDTH = 620
MIN_FLOW_SIDE_PX = 32
FALLBACK_AFTER_S = 1.0  # the speed prior bridges shorter gaps in the road measurements on its own


class OdometryStep(Protocol):
    """Streaming motion estimator in three stages (see the module docstring)."""

    label: str
    motion_stage: str  # the stage name ``motion`` is timed as: "geometry" or "network"
    opencv_threads: int | None  # OpenCV threads per call while streaming (None: OpenCV's default)

    def prepare(self, image: np.ndarray) -> np.ndarray: ...

    def flow(self, previous: np.ndarray, current: np.ndarray) -> Any: ...

    def motion(self, times_s: tuple[float, float], previous: np.ndarray, flow: Any) -> np.ndarray: ...


class _WorkingFrames:
    """Frames resized to ``working_width`` px (never enlarged), intrinsics scaled with them."""

    def __init__(self, intrinsics: CameraIntrinsics, image_size_hw: tuple[int, int], working_width: int) -> None:
        h, w = image_size_hw
        scale = min(1.0, working_width / w)
        self.working_hw = (int(round(h * scale)), int(round(w * scale)))
        self.intrinsics = intrinsics.scaled(self.working_hw[1] / w, self.working_hw[0] / h)
        self.K = self.intrinsics.K
        self.resize = self.working_hw != (h, w)

    def prepare(self, image: np.ndarray) -> np.ndarray:
        """The frame at the working resolution (area interpolation)."""
        if not self.resize:
            return np.ascontiguousarray(image)
        return cv2.resize(image, self.working_hw[::-1], interpolation=cv2.INTER_AREA)


@dataclass(frozen=True)
class GeometryFrame:
    """A working frame of the default method with its textured points and the tracks of the previous
    frame's textured points into it (computed once per frame, in order, in the reader thread; empty for
    the first frame)."""

    image: np.ndarray
    textured_px: np.ndarray
    tracked_prev: np.ndarray
    tracked_next: np.ndarray


@dataclass(frozen=True)
class GeometryFlow:
    """What the default method measures between two working frames: ``motion_prev`` -> ``motion_next``
    (M, 2) tracked textured points for the rotation and translation direction, and ``road_prev`` ->
    ``road_next`` (R, 2) road-band points moved by the dense flow field of the road crop; pixels."""

    motion_prev: np.ndarray
    motion_next: np.ndarray
    road_prev: np.ndarray
    road_next: np.ndarray
    current: np.ndarray  # the current working frame, for the network's fallback distance


class FlowGeometryStep(_WorkingFrames):
    """The default method: tracked points give the essential matrix (rotation, direction); the dense
    flow of the road ahead gives the road plane and with the camera height the metric step; a
    smooth-speed prior filters the steps. With a ``fallback`` network, its distance is the measurement
    once no trustworthy road plane has been seen for ``FALLBACK_AFTER_S``."""

    motion_stage = "geometry"
    opencv_threads: int | None = 1  # its stages balance across the stream's two threads

    def __init__(self, intrinsics: CameraIntrinsics, image_size_hw: tuple[int, int],
                 flow_method: str = DEFAULT_FLOW_METHOD, working_width: int = DEFAULT_WORKING_WIDTH,
                 camera_height_m: float = CAMERA_HEIGHT_M, fallback: CnnStep | None = None) -> None:
        super().__init__(intrinsics, image_size_hw, working_width)
        self.label = f"flowvo ({flow_method} road flow, geometry" + (", network fallback)" if fallback else ")")
        if fallback is not None and (fallback.network.stack != 1 or fallback.working_hw != self.working_hw):
            raise FlowvoError("the fallback network must take one flow field at the default method's frame size")
        self.fallback = fallback
        self.fallback_frames = 0
        self.last_road_time_s = -np.inf
        self.estimator = create_estimator(flow_method)
        self.camera_height_m = camera_height_m
        self.crop = road_crop(self.working_hw, self.K)
        self.road_px = road_grid(self.working_hw, self.K)
        crop_hw = (self.crop[0].stop - self.crop[0].start, self.crop[1].stop - self.crop[1].start)
        if min(crop_hw) < MIN_FLOW_SIDE_PX:  # OpenCV's DIS crashes the process on smaller fields
            raise FlowvoError(f"frames of {image_size_hw[1]}x{image_size_hw[0]} px are too small for the default "
                              f"method: its road crop is {crop_hw[1]}x{crop_hw[0]} px, the flow needs at least "
                              f"{MIN_FLOW_SIDE_PX} px a side (frames at least 90 px high and 64 px wide work)")
        self.crop_origin = np.array([self.crop[1].start, self.crop[0].start], dtype=np.float32)
        self.still_flow_px = STILL_FLOW_PX_AT_620 * self.working_hw[1] / 620.0
        self.threshold_px = 0.25 * self.working_hw[1] / 620.0
        self.speed = SpeedPrior()
        self.last_motion = np.eye(4)
        self._previous: GeometryFrame | None = None

    def prepare(self, image: np.ndarray) -> GeometryFrame:
        """The working frame, its textured points and the tracks from the previous frame (tracking here
        balances the reader and flow threads: measured 85 -> 98 frames/s on two cores, clip 07)."""
        working = super().prepare(image)
        tracked = (np.zeros((0, 2), np.float32),) * 2
        if self._previous is not None:
            tracked = track_points(self._previous.image, working, self._previous.textured_px)
        self._previous = GeometryFrame(working, textured_points(working), *tracked)
        return self._previous

    def flow(self, previous: GeometryFrame, current: GeometryFrame) -> GeometryFlow:
        """Point tracks over the whole frame (from ``prepare``) and the dense flow of the road crop."""
        motion_prev, motion_next = current.tracked_prev, current.tracked_next
        road_flow = self.estimator.estimate(np.ascontiguousarray(previous.image[self.crop]),
                                            np.ascontiguousarray(current.image[self.crop]))
        road_next = follow_flow(self.road_px - self.crop_origin, road_flow) + self.crop_origin
        return GeometryFlow(motion_prev, motion_next, self.road_px, road_next, current.image)

    def motion(self, times_s: tuple[float, float], previous: GeometryFrame, flow: GeometryFlow) -> np.ndarray:
        """``T_prev_cur`` of the step between ``times_s`` (previous, current), seconds."""
        time_s, dt_s = times_s[1], times_s[1] - times_s[0]
        moved_px = np.linalg.norm(flow.motion_next - flow.motion_prev, axis=1)
        road_moved_px = np.linalg.norm(flow.road_next - flow.road_prev, axis=1)
        if np.median(road_moved_px) < self.still_flow_px and (not len(moved_px) or
                                                              np.median(moved_px) < self.still_flow_px):
            self.speed.stop(time_s)  # the road and the scene stand still (distant points alone can mislead)
            self.last_motion = np.eye(4)
            return self.last_motion
        fit = essential_motion(flow.motion_prev, flow.motion_next, self.K, threshold_px=self.threshold_px)
        if fit is None:  # degenerate: keep the last motion (constant velocity)
            return self.last_motion
        step_m = road_step_length_m(flow.road_prev, flow.road_next, self.K, fit, self.camera_height_m)
        if step_m is not None:
            self.last_road_time_s = time_s
        elif self.fallback is not None and time_s - self.last_road_time_s > FALLBACK_AFTER_S:
            # no trustworthy road for a while: the speed prior alone would drift, the network measures
            network_flow = self.fallback.flow(previous.image, flow.current)
            step_m = float(np.linalg.norm(self.fallback.motion(times_s, previous.image, network_flow)[:3, 3]))
            self.fallback_frames += 1
        speed_mps = self.speed.update(time_s, None if step_m is None else step_m / dt_s)
        step_m = 0.0 if speed_mps is None else speed_mps * dt_s
        self.last_motion = invert_se3(se3_next_prev(fit.R, fit.t_dir * step_m))
        return self.last_motion


class CnnStep(_WorkingFrames):
    """The thesis method: a network regresses the motion from the flow field (symmetric inference)."""

    motion_stage = "network"
    opencv_threads: int | None = None

    def __init__(self, intrinsics: CameraIntrinsics, image_size_hw: tuple[int, int], model: OdometryNet,
                 normalization: Normalization, flow_method: str, working_width: int) -> None:
        super().__init__(intrinsics, image_size_hw, working_width)
        if min(self.working_hw) < MIN_FLOW_SIDE_PX:  # OpenCV's DIS crashes the process on smaller fields
            raise FlowvoError(f"frames of {image_size_hw[1]}x{image_size_hw[0]} px are too small for the flow "
                              f"(at least {MIN_FLOW_SIDE_PX} px a side)")
        self.label = f"CNN ({flow_method} flow + network)"
        self.network = DeployableOdometry(model, normalization)
        self.network.predict(np.zeros((1, 2 * self.network.stack, *self.network.input_hw), np.float32))  # warm-up
        self.estimator = create_estimator(flow_method)
        self.past_flows: deque[np.ndarray] = deque(maxlen=self.network.stack)

    def flow(self, previous: np.ndarray, current: np.ndarray) -> np.ndarray:
        """Flow at the network input size, centred on the principal point (2, h, w), pixels."""
        return resize_flow(self.estimator.estimate(previous, current), self.network.input_hw, self.intrinsics.cx)

    @torch.no_grad()
    def motion(self, times_s: tuple[float, float], previous: np.ndarray, flow: np.ndarray) -> np.ndarray:
        """``T_prev_cur`` from the network's distance and heading change (or 6-DoF motion)."""
        if not self.past_flows:  # the first pair stands in for the missing earlier ones, as in training
            self.past_flows.extend([flow] * (self.network.stack - 1))
        self.past_flows.append(flow)
        targets = self.network.predict(np.concatenate(list(self.past_flows))[None])
        if self.network.head == "planar":
            return chain_planar(targets)[-1]
        return chain_se3(se3_from_targets(targets))[-1]


class ClassicalStep:
    """Sparse baseline: KLT corners at full resolution, essential matrix, camera-height scale (or the
    ground-truth step lengths, labelled so, when ``gt_step_lengths_m`` is given)."""

    motion_stage = "geometry"
    opencv_threads: int | None = None

    def __init__(self, intrinsics: CameraIntrinsics, gt_step_lengths_m: np.ndarray | None = None) -> None:
        self.tracker = ClassicalTracker(intrinsics.K, gt_step_lengths_m)
        self.label = "classical VO (KLT + essential matrix, " + (
            "GT scale)" if gt_step_lengths_m is not None else "camera-height scale)")

    def prepare(self, image: np.ndarray) -> np.ndarray:
        """Full-resolution frames."""
        return image

    def flow(self, previous: np.ndarray, current: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """KLT corner tracks."""
        return self.tracker.tracks(previous, current)

    def motion(self, times_s: tuple[float, float], previous: np.ndarray, flow: tuple[np.ndarray, np.ndarray]
               ) -> np.ndarray:
        """``T_prev_cur`` from the tracks."""
        return self.tracker.motion(flow, previous.shape)
