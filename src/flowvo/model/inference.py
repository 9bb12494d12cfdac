"""Inference: network outputs in batches, optional temporal median, chaining into poses."""

from __future__ import annotations

import numpy as np
import torch

from flowvo.geometry import chain_planar, chain_se3, mirror_targets, se3_from_targets
from flowvo.model.data import Normalization, mirror_input, stacked_input
from flowvo.model.network import OdometryNet


@torch.no_grad()
def predict_batch(model: OdometryNet, normalization: Normalization, inputs: torch.Tensor,
                  symmetric: bool = True) -> np.ndarray:
    """Motions (B, D) in physical units of network inputs (B, 2K, h, w) (flow / flow_std_px).

    ``symmetric``: also run the mirrored input and average it, mirrored back, with the direct output.
    Training sees every sample both ways, yet SGD leaves the heading output a small constant offset
    (measured 5e-4 to 1.2e-3 rad per frame, sign varying by epoch) that integrates into large drift;
    the average cancels any such offset exactly, for twice the (small) network cost.
    """
    model.eval()
    if not symmetric:
        return normalization.denormalize(model(inputs).cpu().numpy().astype(np.float64))
    both = model(torch.cat([inputs, mirror_input(inputs)]))
    both = normalization.denormalize(both.cpu().numpy().astype(np.float64))
    direct, mirrored = both[: len(inputs)], both[len(inputs) :]
    return 0.5 * (direct + mirror_targets(mirrored, model.config.head))


@torch.no_grad()
def predict_targets(model: OdometryNet, normalization: Normalization, flows: torch.Tensor, stack: int,
                    device: str = "cpu", batch_size: int = 256, symmetric: bool = True) -> np.ndarray:
    """Motions (N, D) in physical units (m, rad) of every pair of ``flows`` (N, 2, h, w)."""
    outputs = []
    for first in range(0, len(flows), batch_size):
        pairs = range(first, min(first + batch_size, len(flows)))
        batch = torch.stack([stacked_input(flows, p, stack) for p in pairs]).float() / normalization.flow_std_px
        outputs.append(predict_batch(model, normalization, batch.to(device), symmetric))
    return np.concatenate(outputs)


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
