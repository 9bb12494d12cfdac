"""The flow-estimator interface and the registry of methods by name."""

from __future__ import annotations

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


def register(name: str) -> Callable:
    """Class decorator: make an estimator available under ``name``."""

    def decorate(factory: Callable[..., FlowEstimator]) -> Callable[..., FlowEstimator]:
        _FACTORIES[name] = factory
        return factory

    return decorate


def available_methods() -> list[str]:
    """Names of every registered method (some may need weights or optional packages to run)."""
    _load_builtin_methods()
    return sorted(_FACTORIES)


def create_estimator(name: str, weights: str | None = None, device: str = "cpu") -> FlowEstimator:
    """The estimator called ``name``; learned methods need ``weights`` (a local checkpoint path)."""
    _load_builtin_methods()
    if name not in _FACTORIES:
        raise FlowvoError(f"unknown flow method {name!r}; choose one of {', '.join(sorted(_FACTORIES))}")
    factory = _FACTORIES[name]
    if getattr(factory, "learned", False):
        return factory(name=name, weights=weights, device=device)
    return factory(name=name)


def _load_builtin_methods() -> None:
    from flowvo.flow import classical, flownets, raft  # noqa: F401  (registration side effect)
