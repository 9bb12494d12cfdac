"""What the default method (:mod:`flowvo.methods.flowvo`) keeps of a working frame and measures between two: the
frame's textured points and tracks, the tracks and road points of a step. Pixels of the working frame."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from flowvo.odometry.landmark_tracks import Landmarks
from flowvo.odometry.two_view import EssentialMotion


@dataclass(frozen=True)
class GeometryFrame:
    """A working frame of the default method with its textured points, the tracks of the previous frame's
    textured points into it (``tracked_prev`` -> ``tracked_next``; undistorted: ``pair_prev`` -> ``pair_next``,
    with their essential fit ``pair_fit``, None where there is none; ``fit_pending`` until
    :meth:`~flowvo.methods.flowvo.FlowGeometryStep.complete` has made it), and ``continued_next``: where the previous
    frame's tracks (its ``tracked_next``, rows ``continued_rows``) went on to in this frame (computed once per
    frame, in order, in the reader thread; empty for the first frame), and for ``flowvo-ba`` the ``landmarks``
    tracked over many frames (:mod:`flowvo.odometry.landmark_tracks`); ``bottom_px``: where the frame's view of the
    scene ends (a row above the edge of a bonnet or dashboard found across it, :mod:`flowvo.odometry.view_bottom`; the
    image's height without one); ``road_image``: the frame the road's flow is measured on (``image`` without a still
    layer over the road, :mod:`flowvo.odometry.static_layer`; ``image`` itself without one); pixels of the (distorted)
    working frame unless said."""

    image: np.ndarray
    textured_px: np.ndarray
    tracked_prev: np.ndarray
    tracked_next: np.ndarray
    pair_prev: np.ndarray
    pair_next: np.ndarray
    pair_fit: EssentialMotion | None
    continued_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    continued_next: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.float32))
    landmarks: Landmarks | None = None
    fit_pending: bool = False
    bottom_px: int = 0
    road_image: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not self.bottom_px:
            object.__setattr__(self, "bottom_px", self.image.shape[0])
        if self.road_image is None:
            object.__setattr__(self, "road_image", self.image)


@dataclass(frozen=True)
class GeometryFlow:
    """What the default method measures between two working frames, in undistorted pixels: ``motion_prev``
    -> ``motion_next`` (M, 2) tracked textured points for the rotation and translation direction (their essential
    fit ``motion_fit``, None where there is none), and
    ``road_prev`` -> ``road_next`` (R, 2) road-band points that stay in view, moved by the dense flow of the road crop
    from the road key frame (the previous frame, or an earlier one while the road moves little) to the
    current one, with ``key_prev`` -> ``key_next`` the key frame's textured points tracked into the current
    frame (None when the key frame is the previous frame), and ``rotation_key_prev`` -> ``rotation_key_next`` the
    rotation key frame's (:mod:`flowvo.odometry.rotation_key`; None when the step's rotation is measured from the
    previous frame)."""

    motion_prev: np.ndarray
    motion_next: np.ndarray
    motion_fit: EssentialMotion | None
    road_prev: np.ndarray
    road_next: np.ndarray
    current: GeometryFrame
    key_prev: np.ndarray | None = None
    key_next: np.ndarray | None = None
    rotation_key_prev: np.ndarray | None = None
    rotation_key_next: np.ndarray | None = None
