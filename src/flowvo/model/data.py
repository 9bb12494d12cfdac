"""Training samples: flow from a sequence's cache, resized and normalised as at inference
(:mod:`flowvo.model.preprocess`), and motion targets. Sample i is the motion from frame i to i+1; with
``stack`` K it sees the flows of pairs i-K+1..i (the first pair repeated at the start). Mirrored samples
follow :func:`flowvo.model.preprocess.mirror_input` and :func:`flowvo.geometry.mirror_targets`.
"""

from __future__ import annotations

import numpy as np
import torch
from torch.utils.data import Dataset

from flowvo.flow.cache import CHUNK_PAIRS, FlowCache
from flowvo.geometry import mirror_targets, planar_targets, relative_motions, se3_targets
from flowvo.model.preprocess import Normalization, mirror_input, resize_flow
from flowvo.progress import progress


def flow_principal_point_x(cache: FlowCache) -> float:
    """The principal point's column in pixels of the cached flow."""
    return float(cache.sequence.calibration.K0[0, 2]) * cache.flow_size_hw[1] / cache.sequence.image_size_hw[1]


def load_network_flows(cache: FlowCache, input_hw: tuple[int, int], label: str = "") -> torch.Tensor:
    """Every flow of a complete cache, centred on the principal point and at the input size, float16
    (N, 2, h, w)."""
    cx_px = flow_principal_point_x(cache)
    out = torch.empty((cache.n_pairs, 2, *input_hw), dtype=torch.float16)
    chunks = range(0, cache.n_pairs, CHUNK_PAIRS)
    for first in progress(chunks, f"load flow {label}", len(chunks), "chunk"):
        last = min(first + CHUNK_PAIRS, cache.n_pairs)
        for k, flow in enumerate(cache.read_range(first, last)):
            out[first + k] = torch.from_numpy(resize_flow(flow, input_hw, cx_px))
    return out


def motion_targets(T_world_cam: np.ndarray, head: str) -> np.ndarray:
    """Targets (N-1, D) of consecutive poses: planar (distance m, heading change rad) or se3."""
    if head == "planar":
        return planar_targets(T_world_cam)
    return se3_targets(relative_motions(T_world_cam))


def fit_normalization(targets: list[np.ndarray], flows: list[torch.Tensor], head: str, mirror: bool
                      ) -> Normalization:
    """Target mean/std (of the mirrored samples too when ``mirror``) and the flow scale of training data."""
    stacked = np.concatenate(targets)
    if mirror:
        stacked = np.concatenate([stacked, mirror_targets(stacked, head)])
    sample = torch.cat([f[:: max(1, len(f) // 200)].float() for f in flows])
    return Normalization(
        tuple(float(v) for v in stacked.mean(0)),
        tuple(float(max(v, 1e-6)) for v in stacked.std(0)),
        float(max(sample.std().item(), 1e-3)),
    )


def stacked_input(flows: torch.Tensor, pair: int, stack: int) -> torch.Tensor:
    """Channels (2 * stack, h, w) of pairs pair-stack+1..pair, oldest first, clamped at pair 0."""
    indices = [max(0, pair - k) for k in range(stack - 1, -1, -1)]
    return flows[indices].reshape(-1, *flows.shape[-2:])


class OdometryDataset(Dataset):
    """(flow channels, normalised target) over several sequences; with ``mirror`` every sample twice."""

    def __init__(self, flows: list[torch.Tensor], targets: list[np.ndarray], normalization: Normalization,
                 head: str, stack: int, mirror: bool) -> None:
        self.flows = flows
        self.stack = stack
        self.head = head
        self.normalization = normalization
        self.index = [(s, p) for s, f in enumerate(flows) for p in range(len(f))]
        self.targets = [torch.from_numpy(normalization.normalize(t)).float() for t in targets]
        self.mirrored_targets = [
            torch.from_numpy(normalization.normalize(mirror_targets(t, head))).float() for t in targets
        ]
        self.copies = 2 if mirror else 1

    def __len__(self) -> int:
        return len(self.index) * self.copies

    def __getitem__(self, item: int) -> tuple[torch.Tensor, torch.Tensor]:
        mirrored = item >= len(self.index)
        sequence, pair = self.index[item % len(self.index)]
        channels = stacked_input(self.flows[sequence], pair, self.stack).float() / self.normalization.flow_std_px
        if mirrored:
            return mirror_input(channels), self.mirrored_targets[sequence][pair]
        return channels, self.targets[sequence][pair]
