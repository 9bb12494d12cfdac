"""``cnn``: the thesis method. The contracting half of FlowNetS regresses the distance and heading change
(or the 6-DoF motion) from the dense flow field, with symmetric (mirrored) inference."""

from __future__ import annotations

from collections import deque

import numpy as np
import torch

from flowvo.camera import KITTI_CAMERA_HEIGHT_M, Camera
from flowvo.errors import FlowvoError
from flowvo.flow.registry import create_estimator
from flowvo.geometry import chain_planar, chain_se3, se3_from_targets
from flowvo.methods.base import MIN_FLOW_SIDE_PX, NoWindow, WorkingFrames
from flowvo.model.deployable import DeployableOdometry
from flowvo.model.network import OdometryNet
from flowvo.model.preprocess import Normalization, resize_flow

DEFAULT_NETWORK_FLOW_METHOD = "dis-medium"  # for checkpoints that do not record theirs
DEFAULT_NETWORK_INPUT_HW = (188, 620)  # for checkpoints that do not record theirs: KITTI at half size


class CnnStep(NoWindow, WorkingFrames):
    """The network regresses the motion from the flow of undistorted working frames."""

    motion_stage = "network"
    opencv_threads: int | None = None  # one big flow call: OpenCV's pool helps

    def __init__(self, camera: Camera, image_size_hw: tuple[int, int], model: OdometryNet,
                 normalization: Normalization, flow_method: str, working_width: int) -> None:
        super().__init__(camera, image_size_hw, working_width, undistort=True)
        if min(self.working_hw) < MIN_FLOW_SIDE_PX:  # OpenCV's DIS crashes the process on smaller fields
            raise FlowvoError(f"frames of {image_size_hw[1]}x{image_size_hw[0]} px are too small for the flow "
                              f"(at least {MIN_FLOW_SIDE_PX} px a side)")
        self.label = f"cnn ({flow_method} flow + network)"
        self.network = DeployableOdometry(model, normalization)
        self.network.predict(np.zeros((1, 2 * self.network.stack, *self.network.input_hw), np.float32))  # warm-up
        self.estimator = create_estimator(flow_method)
        self.past_flows: deque[np.ndarray] = deque(maxlen=self.network.stack)

    def flow(self, previous: np.ndarray, current: np.ndarray) -> np.ndarray:
        """Flow at the network input size, centred on the principal point (2, h, w), pixels."""
        return resize_flow(self.estimator.estimate(previous, current), self.network.input_hw, self.intrinsics.cx)

    @torch.no_grad()
    def motion(self, times_s: tuple[float, float], previous: np.ndarray, flow: np.ndarray) -> np.ndarray:
        """``T_prev_cur`` from the network's distance and heading change (or 6-DoF motion), metres for the camera's
        height."""
        if not self.past_flows:  # the first pair stands in for the missing earlier ones, as in training
            self.past_flows.extend([flow] * (self.network.stack - 1))
        self.past_flows.append(flow)
        motion = self._motion_of(self.network.predict(np.concatenate(list(self.past_flows))[None]))
        motion[:3, 3] *= self.camera.camera_height_m / KITTI_CAMERA_HEIGHT_M  # the network learned a camera 1.65 m
        # high: the same flow seen from another height is a motion in proportion to it
        return motion

    def _motion_of(self, targets: np.ndarray) -> np.ndarray:
        """``T_prev_cur`` of the network's outputs (1, D)."""
        if self.network.head == "planar":
            return chain_planar(targets)[-1]
        return chain_se3(se3_from_targets(targets))[-1]

    def distance_m(self, previous_working: np.ndarray, current_working: np.ndarray) -> float:
        """The network's step length (metres) between two working frames that are not yet undistorted (a
        single-field network only: it keeps no history)."""
        flow = self.flow(self.undistort(previous_working), self.undistort(current_working))
        return float(np.linalg.norm(self._motion_of(self.network.predict(flow[None]))[:3, 3]))


def load_cnn_step(camera: Camera, image_size_hw: tuple[int, int], model_path: str | None,
                  flow_method: str | None = None) -> CnnStep:
    """The thesis network's step (``model_path`` or the packaged model) with the flow it was trained on, at
    the frame width it was trained on."""
    from flowvo.model.checkpoint import load_model, packaged_model_path

    model, normalization, state = load_model(model_path or packaged_model_path())
    flow_method = flow_method or state.get("train_config", {}).get("flow_method", DEFAULT_NETWORK_FLOW_METHOD)
    trained_hw = state.get("flow_size_hw") or DEFAULT_NETWORK_INPUT_HW
    return CnnStep(camera, image_size_hw, model, normalization, flow_method, working_width=int(trained_hw[1]))
