"""flowvo: monocular visual odometry from dense optical flow, with metric scale from the road.

The Python API (``docs/api.md``): :class:`flowvo.Camera`, :class:`flowvo.Odometry` (frames pushed one at a time),
:func:`flowvo.run` (a whole drive), :class:`flowvo.Trajectory` of :class:`flowvo.Pose`, :func:`flowvo.evaluate`;
bad input raises :class:`flowvo.FlowvoError`.
Each is imported when first used: ``import flowvo`` loads neither torch nor OpenCV.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from flowvo._version import VERSION as __version__

if TYPE_CHECKING:
    from flowvo.api import Camera, Evaluation, Odometry, Pose, Trajectory, evaluate, run
    from flowvo.errors import FlowvoError

__all__ = ["Camera", "Evaluation", "FlowvoError", "Odometry", "Pose", "Trajectory", "__version__", "evaluate", "run"]
_API = frozenset(__all__) - {"__version__", "FlowvoError"}


def __getattr__(name: str) -> Any:
    if name == "FlowvoError":  # every bad input raises it (the CLI prints it as one line, exit 2)
        from flowvo.errors import FlowvoError

        return FlowvoError
    if name in _API:
        import flowvo.api

        return getattr(flowvo.api, name)
    raise AttributeError(f"module 'flowvo' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(list(globals()) + __all__)
