"""The odometry methods: one module each, one row each in :data:`METHODS`, which the CLI choices, the stage
names of run/bench/report and the docs read from. Adding a method = one module + one row.

Builders import their module only when called, so listing the methods (``flowvo --help``) needs no torch.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from flowvo.errors import FlowvoError
from flowvo.geometry import planar_targets

if TYPE_CHECKING:
    from flowvo.camera import Camera
    from flowvo.methods.base import OdometryStep
    from flowvo.sources.base import FrameSource


@dataclass(frozen=True)
class MethodOptions:
    """What a method is built with, besides its drive: its ``name``, the network checkpoint (``model``; None: the
    packaged one), the ``flow_method`` (None: the method's own), the scale window's ``latency_frames`` (None: its
    default) and the classical method's scale (``classical_scale``: "height", or "gt" for the true step lengths)."""

    name: str
    model: str | None = None
    flow_method: str | None = None
    latency_frames: int | None = None
    classical_scale: str = "height"


@dataclass(frozen=True)
class Method:
    """A method by name: one line for ``--help`` and the docs, the per-frame stages it has (for timing
    tables), and how to build its per-frame step for a drive."""

    name: str
    summary: str
    stages: tuple[str, ...]
    build: Callable[[MethodOptions, FrameSource, Camera], OdometryStep]

    @property
    def windowed(self) -> bool:
        """True for a method with a scale window (``--latency`` applies)."""
        return "window" in self.stages


def _flowvo(with_network: bool, with_window: bool, with_bundle: bool = False) -> Callable[..., Any]:
    def build(options: MethodOptions, source: FrameSource, camera: Camera) -> OdometryStep:
        from flowvo.methods.cnn import load_cnn_step
        from flowvo.methods.flowvo import DEFAULT_ROAD_FLOW_METHOD, FlowGeometryStep
        from flowvo.odometry.bundle_window import BundleSettings
        from flowvo.odometry.scale_window import ScaleWindow

        if not with_window:
            _no_latency(options)
        fallback = load_cnn_step(camera, source.image_size_hw, options.model) if with_network else None
        window = None
        if with_window:
            window = ScaleWindow() if options.latency_frames is None else ScaleWindow(options.latency_frames)
        return FlowGeometryStep(camera, source.image_size_hw, flow_method=options.flow_method or
                                DEFAULT_ROAD_FLOW_METHOD, fallback=fallback, window=window,
                                bundle=BundleSettings() if with_bundle else None)
    return build


def _no_latency(options: MethodOptions) -> None:
    """Refuse ``--latency`` for a method without a scale window (its poses are final at once)."""
    if options.latency_frames:
        raise FlowvoError("--latency applies to the windowed methods (flowvo, flowvo-geometry, flowvo-ba); "
                          f"{options.name} gives every pose at once")


def _cnn(options: MethodOptions, source: FrameSource, camera: Camera) -> OdometryStep:
    from flowvo.methods.cnn import load_cnn_step

    _no_latency(options)
    return load_cnn_step(camera, source.image_size_hw, options.model, options.flow_method)


def _classical(options: MethodOptions, source: FrameSource, camera: Camera) -> OdometryStep:
    from flowvo.methods.classical import ClassicalStep

    _no_latency(options)
    steps = None
    if options.classical_scale == "gt":
        if source.ground_truth is None:
            raise FlowvoError("--scale-from gt needs ground-truth poses, and this drive has none")
        steps = planar_targets(source.ground_truth.T_world_cam)[:, 0]
    return ClassicalStep(camera, steps, source.image_size_hw)


_GEOMETRY_STAGES = ("image_read", "flow", "geometry", "chaining")  # flowvo's rare network fallback is geometry
_WINDOW_STAGES = ("image_read", "flow", "geometry", "window", "chaining")
METHODS: dict[str, Method] = {method.name: method for method in (
    Method("flowvo", "default: tracked points + dense road flow, road-plane scale from the camera height, step "
                     "lengths refined over a 2 s window (three-view ratios; poses 5 frames late), the packaged "
                     "network where no road is seen", _WINDOW_STAGES, _flowvo(with_network=True, with_window=True)),
    Method("flowvo-geometry", "the default without the network", _WINDOW_STAGES,
           _flowvo(with_network=False, with_window=True)),
    Method("flowvo-ba", "the default with a local bundle adjustment of the last 10 frames' poses and tracked points "
                        "behind the scale window, its translations taken (GTSAM; poses 9 frames later, several times "
                        "slower)", _WINDOW_STAGES,
           _flowvo(with_network=True, with_window=True, with_bundle=True)),
    Method("flowvo-pair", "the default's per-pair estimate: each step from its own two frames and a speed prior, "
                          "no latency", _GEOMETRY_STAGES, _flowvo(with_network=True, with_window=False)),
    Method("cnn", "the thesis network (--model, default the packaged one) on the flow field",
           ("image_read", "flow", "network", "chaining"), _cnn),
    Method("classical", "KLT corners + essential matrix, camera-height scale (or --scale-from gt)",
           _GEOMETRY_STAGES, _classical),
)}
DEFAULT_METHOD = "flowvo"


def method(name: str) -> Method:
    """The method called ``name``; a one-line error naming the choices otherwise."""
    if name not in METHODS:
        raise FlowvoError(f"unknown method {name!r}; choose one of {', '.join(METHODS)}")
    return METHODS[name]


def methods_help() -> str:
    """One sentence per method for ``--help``."""
    return "; ".join(f"{m.name}: {m.summary}" for m in METHODS.values())
