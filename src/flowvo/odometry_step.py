"""The one per-frame odometry step, shared by ``run`` (KITTI folders, video, bags), ``bench`` and the demo.

A step is fed grey frames one at a time (``start`` with the first, ``push`` with each next) and returns the
camera motion ``T_prev_cur`` (4x4: the current camera's pose in the previous camera's frame, metres) with
the seconds each stage took. Steps keep what they need from earlier frames (the resized previous frame,
past flows for a stacked network, the speed history), so every caller runs exactly the same inference.

Methods:
- ``flowvo`` (default): dense DIS flow; rotation and translation direction from an essential matrix
  fitted to flow at textured points; metric step length from the road plane at the known camera height,
  filtered by a smooth-speed prior; standstill when the flow is below half a pixel. No ground truth.
- ``cnn``: the thesis network (distance and heading change regressed from the flow field).
- ``classical``: KLT corners + essential matrix, scale from the camera height (sparse baseline).
"""

from __future__ import annotations

import time
from collections import deque
from typing import Protocol

import cv2
import numpy as np
import torch

from flowvo.classical_vo import CAMERA_HEIGHT_M, ClassicalTracker
from flowvo.flow.registry import create_estimator
from flowvo.flow_geometry import (
    essential_motion,
    follow_flow,
    road_step_length_m,
    sample_points,
    se3_next_prev,
)
from flowvo.geometry import chain_planar, chain_se3, invert_se3, se3_from_targets
from flowvo.model.data import Normalization, resize_flow
from flowvo.model.inference import predict_batch
from flowvo.model.network import OdometryNet
from flowvo.sources.base import CameraIntrinsics
from flowvo.speed_prior import SpeedPrior

STILL_FLOW_PX_AT_620 = 0.5
DEFAULT_FLOW_METHOD = "dis-medium-fine"


class OdometryStep(Protocol):
    """Streaming motion estimator (see the module docstring)."""

    label: str

    def start(self, time_s: float, image: np.ndarray) -> None: ...

    def push(self, time_s: float, image: np.ndarray) -> tuple[np.ndarray, dict[str, float]]: ...


class _ResizingStep:
    """Shared frame handling: frames resized to ``working_width`` px, intrinsics scaled with them."""

    def __init__(self, intrinsics: CameraIntrinsics, image_size_hw: tuple[int, int], working_width: int) -> None:
        h, w = image_size_hw
        self.scale = min(1.0, working_width / w)
        self.working_hw = (int(round(h * self.scale)), int(round(w * self.scale)))
        sy, sx = self.working_hw[0] / h, self.working_hw[1] / w
        self.intrinsics = intrinsics.scaled(sx, sy)
        self.K = self.intrinsics.K
        self.still_flow_px = STILL_FLOW_PX_AT_620 * self.working_hw[1] / 620.0
        self.previous: np.ndarray | None = None
        self.previous_time_s = 0.0

    def _resize(self, image: np.ndarray) -> np.ndarray:
        if self.scale == 1.0:
            return np.ascontiguousarray(image)
        return cv2.resize(image, self.working_hw[::-1], interpolation=cv2.INTER_AREA)

    def start(self, time_s: float, image: np.ndarray) -> None:
        """The first frame."""
        self.previous, self.previous_time_s = self._resize(image), time_s


class FlowGeometryStep(_ResizingStep):
    """The default method: dense flow, essential matrix, road-plane scale, smooth-speed prior."""

    def __init__(self, intrinsics: CameraIntrinsics, image_size_hw: tuple[int, int],
                 flow_method: str = DEFAULT_FLOW_METHOD, working_width: int = 620,
                 camera_height_m: float = CAMERA_HEIGHT_M) -> None:
        super().__init__(intrinsics, image_size_hw, working_width)
        self.label = f"flowvo ({flow_method} flow + geometry, road-plane scale)"
        self.flow = create_estimator(flow_method)
        self.camera_height_m = camera_height_m
        self.speed = SpeedPrior()
        self.last_motion = np.eye(4)

    def push(self, time_s: float, image: np.ndarray) -> tuple[np.ndarray, dict[str, float]]:
        """Motion ``T_prev_cur`` from the previous frame to ``image`` and seconds per stage."""
        t0 = time.perf_counter()
        current = self._resize(image)
        flow = self.flow.estimate(self.previous, current)
        t1 = time.perf_counter()
        motion = self._motion(self.previous, flow, time_s)
        t2 = time.perf_counter()
        self.previous, self.previous_time_s = current, time_s
        return motion, {"flow": t1 - t0, "geometry": t2 - t1}

    def _motion(self, previous: np.ndarray, flow: np.ndarray, time_s: float) -> np.ndarray:
        dt_s = max(time_s - self.previous_time_s, 1e-6)
        samples = sample_points(previous, self.K)
        moved = follow_flow(samples.motion_px, flow)
        if np.median(np.linalg.norm(moved - samples.motion_px, axis=1)) < self.still_flow_px:
            self.speed.stop(time_s)
            self.last_motion = np.eye(4)
            return self.last_motion
        fit = essential_motion(samples.motion_px, moved, self.K, threshold_px=0.25 * self.working_hw[1] / 620.0)
        if fit is None:  # degenerate: keep the last motion (constant-velocity assumption)
            return self.last_motion
        road_moved = follow_flow(samples.road_px, flow)
        step_m = road_step_length_m(samples.road_px, road_moved, self.K, fit, self.camera_height_m)
        speed = self.speed.update(time_s, None if step_m is None else step_m / dt_s)
        step_m = 0.0 if speed is None else speed * dt_s
        self.last_motion = invert_se3(se3_next_prev(fit.R, fit.t_dir * step_m))
        return self.last_motion


class CnnStep(_ResizingStep):
    """The thesis method: a network regresses the motion from the flow field (symmetric inference)."""

    def __init__(self, intrinsics: CameraIntrinsics, image_size_hw: tuple[int, int], model: OdometryNet,
                 normalization: Normalization, flow_method: str, working_width: int) -> None:
        super().__init__(intrinsics, image_size_hw, working_width)
        self.label = f"CNN ({flow_method} flow + network)"
        self.model, self.normalization = model.eval(), normalization
        self.flow = create_estimator(flow_method)
        self.past_flows: deque[torch.Tensor] = deque(maxlen=model.config.stack)

    def push(self, time_s: float, image: np.ndarray) -> tuple[np.ndarray, dict[str, float]]:
        """Motion ``T_prev_cur`` and seconds per stage."""
        t0 = time.perf_counter()
        current = self._resize(image)
        flow = self.flow.estimate(self.previous, current)
        t1 = time.perf_counter()
        channels = torch.from_numpy(resize_flow(flow, self.model.config.input_hw, self.intrinsics.cx))
        if not self.past_flows:  # the first pair stands in for the missing earlier ones, as in training
            self.past_flows.extend([channels] * (self.model.config.stack - 1))
        self.past_flows.append(channels)
        inputs = torch.cat(list(self.past_flows))[None] / self.normalization.flow_std_px
        targets = predict_batch(self.model, self.normalization, inputs)
        if self.model.config.head == "planar":
            motion = chain_planar(targets)[-1]
        else:
            motion = chain_se3(se3_from_targets(targets))[-1]
        t2 = time.perf_counter()
        self.previous, self.previous_time_s = current, time_s
        return motion, {"flow": t1 - t0, "network": t2 - t1}


class ClassicalStep:
    """Sparse baseline: KLT corners at full resolution, essential matrix, camera-height scale (or the
    ground-truth step lengths, labelled so, when ``gt_step_lengths_m`` is given)."""

    def __init__(self, intrinsics: CameraIntrinsics, gt_step_lengths_m: np.ndarray | None = None) -> None:
        self.tracker = ClassicalTracker(intrinsics.K, gt_step_lengths_m)
        self.label = "classical VO (KLT + essential matrix, " + (
            "GT scale)" if gt_step_lengths_m is not None else "camera-height scale)")

    def start(self, time_s: float, image: np.ndarray) -> None:
        """The first frame."""
        self.tracker.start(image)

    def push(self, time_s: float, image: np.ndarray) -> tuple[np.ndarray, dict[str, float]]:
        """Motion ``T_prev_cur``; KLT tracking and the essential matrix count as the flow stage."""
        t0 = time.perf_counter()
        motion = self.tracker.push(image)
        return motion, {"flow": time.perf_counter() - t0}
