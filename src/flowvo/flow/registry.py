"""The flow-estimator interface and the registry of methods by name."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Protocol

import numpy as np

from flowvo.errors import FlowvoError


class FlowEstimator(Protocol):
    """Estimates forward flow between two grey uint8 frames of equal size."""

    def estimate(self, prev: np.ndarray, next: np.ndarray) -> np.ndarray:
        """Flow (H, W, 2) float32 from ``prev`` to ``next``: u right, v down, pixels."""
        ...

    def params(self) -> dict:
        """Parameters that determine the result (recorded in cache metadata)."""
        ...


_FACTORIES: dict[str, Callable[..., FlowEstimator]] = {}

# Learned methods by "module:class", imported only when created: listing the methods (the CLI's --help)
# then needs no torch.
_LEARNED: dict[str, str] = {
    "flownets": "flowvo.flow.flownets:FlowNetSFlow",
    "raft-small": "flowvo.flow.raft:RaftFlow",
    "raft-large": "flowvo.flow.raft:RaftFlow",
}


def register(name: str) -> Callable:
    """Class decorator: make an estimator constructed from its ``name`` alone available under ``name``."""

    def decorate(factory: Callable[..., FlowEstimator]) -> Callable[..., FlowEstimator]:
        _FACTORIES[name] = factory
        return factory

    return decorate


def available_methods() -> list[str]:
    """Names of every registered method (some may need weights or optional packages to run)."""
    _load_classical_methods()
    return sorted(set(_FACTORIES) | set(_LEARNED))


def create_estimator(name: str, weights: str | None = None, device: str = "cpu") -> FlowEstimator:
    """The estimator called ``name``; learned methods need ``weights`` (a local checkpoint path)."""
    _load_classical_methods()
    if name in _LEARNED:
        module, attribute = _LEARNED[name].split(":")
        return getattr(importlib.import_module(module), attribute)(name=name, weights=weights, device=device)
    if name not in _FACTORIES:
        raise FlowvoError(f"unknown flow method {name!r}; choose one of {', '.join(available_methods())}")
    return _FACTORIES[name](name=name)


def _load_classical_methods() -> None:
    from flowvo.flow import classical  # noqa: F401  (registration side effect)
