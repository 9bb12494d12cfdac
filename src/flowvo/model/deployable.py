"""The deployable odometry network: resized flow in pixels in, motion in metres and radians out.

One module holds every step between the flow at the network input size and the physical motion: flow
normalisation, the network, the symmetric mirrored pass and target de-normalisation. The PyTorch path,
the TorchScript file and the ONNX file all run this module, so they cannot disagree on a convention.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from torch import nn

from flowvo.geometry import TARGET_NAMES, mirror_targets
from flowvo.model.checkpoint import load_model
from flowvo.model.network import OdometryNet
from flowvo.model.preprocess import Normalization, mirror_input


class DeployableOdometry(nn.Module):
    """Flow (B, 2K, h, w) float32 -> motion (B, D) float32 in metres and radians.

    Input: K consecutive flow fields, oldest first, channels (u, v) per field, u right, v down, in pixels
    of the network input (h, w) = ``input_hw``: the flow already centred on the principal point column
    and resized, exactly as :func:`flowvo.model.preprocess.resize_flow` returns it. Output: the motion from the
    last field's first frame to its second, components ``output_names`` (planar: distance m and heading
    change rad, positive turning right; se3: translation m then axis-angle rad, camera frame of the first
    frame).

    ``symmetric``: also run the left-right mirrored input and average its output, mirrored back by the
    rule of :func:`flowvo.geometry.mirror_targets`, with the direct output. Training sees every sample
    both ways, yet SGD leaves the heading output a small constant offset (measured 5e-4 to 1.2e-3 rad
    per frame, sign varying by epoch) that integrates into large drift; the average cancels any such
    offset exactly, for twice the network cost.

    The network is put in eval mode; its weights are shared, not copied (wrapping a network in training
    evaluates the current weights).
    """

    def __init__(self, network: OdometryNet, normalization: Normalization, symmetric: bool = True) -> None:
        super().__init__()
        self.network = network
        self.symmetric = symmetric
        device = next(network.parameters()).device

        def constant(values: float | tuple[float, ...] | np.ndarray) -> torch.Tensor:
            return torch.as_tensor(np.asarray(values, dtype=np.float32), device=device)

        self.register_buffer("flow_std_px", constant(normalization.flow_std_px))
        self.register_buffer("target_mean", constant(normalization.target_mean))
        self.register_buffer("target_std", constant(normalization.target_std))
        self.register_buffer("target_mirror_signs", constant(mirror_targets(np.ones(network.config.outputs),
                                                                            network.config.head)))
        self.eval()

    @classmethod
    def from_checkpoint(cls, path: str | Path, symmetric: bool = True) -> DeployableOdometry:
        """The module of a flowvo checkpoint (full or slim), float32 weights on the CPU."""
        network, normalization, _ = load_model(path)
        return cls(network, normalization, symmetric)

    @property
    def input_hw(self) -> tuple[int, int]:
        """Network input (height, width) in pixels."""
        return self.network.config.input_hw

    @property
    def stack(self) -> int:
        """K, the number of consecutive flow fields in the input (2K channels)."""
        return self.network.config.stack

    @property
    def head(self) -> str:
        """"planar" (distance, heading change) or "se3" (translation, axis-angle)."""
        return self.network.config.head

    @property
    def output_names(self) -> tuple[str, ...]:
        """Names of the D output components, units in the suffix (``distance_m``, ``heading_rad``, ...)."""
        return TARGET_NAMES[self.head]

    def forward(self, flow_px: torch.Tensor) -> torch.Tensor:
        inputs = flow_px / self.flow_std_px
        if not self.symmetric:
            return self._denormalize(self.network(inputs))
        both = self._denormalize(self.network(torch.cat([inputs, mirror_input(inputs)])))
        both = both.reshape(2, -1, len(self.output_names))  # (direct, mirrored), batch size left dynamic
        return 0.5 * (both[0] + both[1] * self.target_mirror_signs)

    def _denormalize(self, outputs: torch.Tensor) -> torch.Tensor:
        return outputs * self.target_std + self.target_mean

    @torch.no_grad()
    def predict(self, flow_px: np.ndarray | torch.Tensor) -> np.ndarray:
        """Motion (B, D) float64 (m, rad) of flow (B, 2K, h, w) in pixels; any float dtype or device."""
        inputs = torch.as_tensor(flow_px, dtype=torch.float32, device=self.flow_std_px.device)
        return self(inputs).cpu().numpy().astype(np.float64)
