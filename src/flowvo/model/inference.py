"""Inference in batches (training validation) and chaining into poses.

Every path runs :class:`flowvo.model.deployable.DeployableOdometry`, the one rule from resized flow to
physical motion (normalisation, symmetric mirrored pass, de-normalisation).
"""

from __future__ import annotations

import numpy as np
import torch

from flowvo.geometry import chain_planar, chain_se3, se3_from_targets
from flowvo.model.data import stacked_input
from flowvo.model.deployable import DeployableOdometry
from flowvo.model.network import OdometryNet
from flowvo.model.preprocess import Normalization


def predict_targets(model: OdometryNet, normalization: Normalization, flows: torch.Tensor, stack: int,
                    device: str = "cpu", batch_size: int = 256, symmetric: bool = True) -> np.ndarray:
    """Motions (N, D) float64 in physical units (m, rad) of every pair of ``flows`` (N, 2, h, w), pixels of
    the network input (as :func:`flowvo.model.data.load_network_flows` returns them), pair i stacked with
    its ``stack`` - 1 predecessors."""
    deployable = DeployableOdometry(model, normalization, symmetric)
    outputs = []
    for first in range(0, len(flows), batch_size):
        pairs = range(first, min(first + batch_size, len(flows)))
        batch = torch.stack([stacked_input(flows, p, stack) for p in pairs]).to(device)
        outputs.append(deployable.predict(batch))
    return np.concatenate(outputs)


def chain_motions(targets: np.ndarray, head: str) -> np.ndarray:
    """Poses (N+1, 4, 4) from motions: planar (distance, heading change) or se3 targets."""
    if head == "planar":
        return chain_planar(targets)
    return chain_se3(se3_from_targets(targets))
