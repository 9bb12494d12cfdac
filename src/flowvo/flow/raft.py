"""RAFT (small and large) from torchvision, when torchvision is installed and local weights are given.

torchvision is not a dependency: the build that matches our torch 2.13.0 CPU wheel is not on PyPI
(PyPI's wheel fails to import beside it), so RAFT is for users who bring a matching torchvision.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from flowvo.errors import FlowvoError
from flowvo.io.torch_files import load_torch_file


class RaftFlow:
    """torchvision's RAFT with a local state_dict; frames padded to multiples of 8."""

    def __init__(self, name: str, weights: str | Path | None, device: str = "cpu") -> None:
        try:
            from torchvision.models import optical_flow
        except ImportError:
            message = f"{name} needs torchvision, which flowvo does not install (see flowvo.flow.raft)"
            raise FlowvoError(message) from None
        if weights is None or not Path(weights).is_file():
            raise FlowvoError(
                f"{name} needs local weights: pass --flow-weights PATH to a torchvision RAFT state_dict "
                "(torchvision's Raft_Small_Weights / Raft_Large_Weights files); flowvo never downloads"
            )
        builder = optical_flow.raft_small if name == "raft-small" else optical_flow.raft_large
        self.model = builder(weights=None)
        self.model.load_state_dict(load_torch_file(weights))
        self.model.eval().to(device)
        self.name, self.weights, self.device = name, str(weights), device

    @torch.no_grad()
    def estimate(self, prev: np.ndarray, next: np.ndarray) -> np.ndarray:
        h, w = prev.shape[:2]
        ph, pw = -(-h // 8) * 8, -(-w // 8) * 8

        def prepare(image: np.ndarray) -> torch.Tensor:
            rgb = np.repeat(image[..., None], 3, axis=2) if image.ndim == 2 else image[..., ::-1]
            tensor = torch.from_numpy(np.ascontiguousarray(rgb)).float().permute(2, 0, 1)[None] / 127.5 - 1.0
            return torch.nn.functional.pad(tensor, (0, pw - w, 0, ph - h), mode="replicate").to(self.device)

        flow = self.model(prepare(prev), prepare(next))[-1]
        return flow[0, :, :h, :w].permute(1, 2, 0).cpu().numpy().astype(np.float32)

    def params(self) -> dict:
        return {"weights": self.weights}

