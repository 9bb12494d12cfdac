"""The flow-estimator interface and the registry of methods by name."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Protocol

import numpy as np

from flowvo.errors import FlowvoError
from flowvo.flow.classical import DIS_PRESETS, DisFlow, FarnebackFlow


class FlowEstimator(Protocol):
    """Estimates forward flow between two grey uint8 frames of equal size."""

    def estimate(self, prev: np.ndarray, next: np.ndarray) -> np.ndarray:
        """Flow (H, W, 2) float32 from ``prev`` to ``next``: u right, v down, pixels."""
        ...

    def params(self) -> dict:
        """Parameters that determine the result (recorded in cache metadata)."""
        ...


_FACTORIES: dict[str, Callable[..., FlowEstimator]] = {**dict.fromkeys(DIS_PRESETS, DisFlow),
                                                       "farneback": FarnebackFlow}

# Learned methods by "module:class", imported only when created: listing the methods (the CLI's --help)
# then needs no torch.
_LEARNED: dict[str, str] = {
    "flownets": "flowvo.flow.flownets:FlowNetSFlow",
    "raft-small": "flowvo.flow.raft:RaftFlow",
    "raft-large": "flowvo.flow.raft:RaftFlow",
}


def available_methods() -> list[str]:
    """Names of every registered method (some may need weights or optional packages to run)."""
    return sorted(set(_FACTORIES) | set(_LEARNED))


def create_estimator(name: str, weights: str | None = None, device: str = "cpu") -> FlowEstimator:
    """The estimator called ``name``; learned methods need ``weights`` (a local checkpoint path)."""
    if name in _LEARNED:
        module, attribute = _LEARNED[name].split(":")
        return getattr(importlib.import_module(module), attribute)(name=name, weights=weights, device=device)
    if name not in _FACTORIES:
        raise FlowvoError(f"unknown flow method {name!r}; choose one of {', '.join(available_methods())}")
    return _FACTORIES[name](name=name)

