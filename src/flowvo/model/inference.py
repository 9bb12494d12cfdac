"""Inference: network outputs in batches, optional temporal median, chaining into poses."""

from __future__ import annotations

import numpy as np
import torch

from flowvo.geometry import chain_planar, chain_se3, se3_from_targets
from flowvo.model.data import Normalization, stacked_input
from flowvo.model.network import OdometryNet


@torch.no_grad()
def predict_targets(model: OdometryNet, normalization: Normalization, flows: torch.Tensor, stack: int,
                    device: str = "cpu", batch_size: int = 256) -> np.ndarray:
    """Motions (N, D) in physical units (m, rad) of every pair of ``flows`` (N, 2, h, w)."""
    model.eval()
    outputs = []
    for first in range(0, len(flows), batch_size):
        pairs = range(first, min(first + batch_size, len(flows)))
        batch = torch.stack([stacked_input(flows, p, stack) for p in pairs]).float() / normalization.flow_std_px
        outputs.append(model(batch.to(device)).cpu().numpy())
    return normalization.denormalize(np.concatenate(outputs).astype(np.float64))


def temporal_median(targets: np.ndarray, window: int) -> np.ndarray:
    """Causal median over the last ``window`` predictions, per component (window 1 = unchanged)."""
    if window <= 1:
        return targets
    return np.stack([np.median(targets[max(0, i - window + 1) : i + 1], axis=0) for i in range(len(targets))])


def chain_motions(targets: np.ndarray, head: str) -> np.ndarray:
    """Poses (N+1, 4, 4) from motions: planar (distance, heading change) or se3 targets."""
    if head == "planar":
        return chain_planar(targets)
    return chain_se3(se3_from_targets(targets))
