"""Point correspondences between frames far enough apart to show the camera's rotation, from a stream of
frames: the input of :mod:`flowvo.calibration.focal_from_motion`.

Textured points (:func:`flowvo.odometry.two_view.textured_points`) of a start frame are tracked frame to frame
(Lucas-Kanade, each step checked forward-backward) until fewer than ``END_POINTS`` are left (the others left
the view, were occluded or failed the check); the start frame and the frame before that then form a pair. A new start
frame is taken whenever the newest chain has moved ``START_MOTION_PX``, so pairs overlap and adapt to the
speed and the frame rate by themselves (a standing car starts no new chain). Pure functions over NumPy
arrays; pixels of the frames given (x right, y down).

Parts of the frame that do not move with the scene (the car's bonnet or dashboard) are found from the pairs
themselves and left out (:func:`without_still_regions`): in the lower part of the frame a moving camera sees
every point of the scene move.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from flowvo.odometry.still_regions import STILL_SHARE, StillRegions
from flowvo.odometry.two_view import textured_points, track_points_checked

CHAIN_POINTS = 1500  # textured points per start frame: at 620 px wide nearly every 8 px cell of the frame
RETURN_PX = 1.0  # forward-backward check: a track must return within this (compressed video: ~0.5 px noise)
END_POINTS = 300  # a chain ends when fewer of its points are left: longer chains see more rotation (what
# shows the focal length) over fewer points and more drift; 200-400 moved the KITTI clips' estimates by 1-3 %,
# 200 put a synthetic drive past facades of repeated windows 10 % off, 300 4 %
MOTION_PERCENTILE = 90  # how far a chain moved: this percentile of its tracks (the median stays near 0 where
# most texture is far away: sky, distant hills)
START_MOTION_PX = 40.0  # a new chain starts when the newest has moved this far (as many pairs as a median of
# 20 px gave on the KITTI clips, with estimates within 1 % of those)
MIN_PAIR_POINTS = 60  # fewer correspondences cannot tell a focal length from noise
MIN_PAIR_MOTION_PX = 5.0  # a pair whose points moved less than this shows no usable motion
STILL_TRACKS_FROM = 0.25  # frame heights below the centre: from there down parts of the frame are judged for
# standing still (as the default method judges its tracks, methods/flowvo.py): the real dash-cam's bonnet held
# a third of the tracks of its turning frame pairs, moving 0.5-1.4 px (median)


@dataclass(frozen=True)
class PointPair:
    """Correspondences between frames ``first`` and ``second`` (indices in the stream): ``first_px`` and
    ``second_px`` (N, 2) float32, the same points in both frames, pixels."""

    first: int
    second: int
    first_px: np.ndarray
    second_px: np.ndarray



@dataclass
class _Chain:
    """Points of frame ``start`` (``start_px``) followed to the latest frame (``current_px``)."""

    start: int
    start_px: np.ndarray
    current_px: np.ndarray


def motion_pairs(frames: Iterable[np.ndarray], scale_px: float = 1.0) -> list[PointPair]:
    """The correspondence pairs of a stream of grey frames (H, W) uint8, in stream order of their start
    frames (see the module docstring). ``scale_px``: the frames' width over 620 px, the width the pixel
    thresholds are set at."""
    pairs: list[PointPair] = []
    chains: list[_Chain] = []
    previous: np.ndarray | None = None
    index = -1
    for index, image in enumerate(frames):
        if previous is not None and chains:
            chains = _advance(chains, previous, image, index, scale_px, pairs)
        if not chains or _moved_px(chains[-1]) >= START_MOTION_PX * scale_px:
            start_px = textured_points(image, CHAIN_POINTS)
            chains.append(_Chain(index, start_px, start_px))
        previous = image
    for chain in chains:  # the stream ended: the chains still alive span to its last frame
        _emit(chain, index, scale_px, pairs)
    return sorted(pairs, key=lambda pair: pair.first)


def _advance(chains: list[_Chain], previous: np.ndarray, image: np.ndarray, index: int, scale_px: float,
             pairs: list[PointPair]) -> list[_Chain]:
    """Track every chain's points into ``image`` (one Lucas-Kanade call for all); chains that lost too many
    points end at the frame before and become pairs. Returns the chains still alive."""
    moved, kept = track_points_checked(previous, image, np.concatenate([c.current_px for c in chains]),
                                       RETURN_PX * scale_px)
    alive = []
    offset = 0
    for chain in chains:
        n = len(chain.current_px)
        chain_kept = kept[offset : offset + n]
        if chain_kept.sum() < END_POINTS:
            _emit(chain, index - 1, scale_px, pairs)
        else:
            alive.append(_Chain(chain.start, chain.start_px[chain_kept], moved[offset : offset + n][chain_kept]))
        offset += n
    return alive


def _emit(chain: _Chain, last: int, scale_px: float, pairs: list[PointPair]) -> None:
    """Add the chain as the pair (start, last) when it has enough points that moved enough."""
    if last > chain.start and len(chain.start_px) >= MIN_PAIR_POINTS \
            and _moved_px(chain) >= MIN_PAIR_MOTION_PX * scale_px:
        pairs.append(PointPair(chain.start, last, chain.start_px, chain.current_px))


def _moved_px(chain: _Chain) -> float:
    """How far the chain's points moved since its start frame (``MOTION_PERCENTILE``), pixels."""
    if not len(chain.start_px):
        return 0.0
    return float(np.percentile(np.linalg.norm(chain.current_px - chain.start_px, axis=1), MOTION_PERCENTILE))


def without_still_regions(pairs: list[PointPair], image_size_hw: tuple[int, int], scale_px: float = 1.0
                          ) -> tuple[list[PointPair], float]:
    """The pairs without their points in the parts of the frame that do not move with the scene, and the
    share of the frame's cells found so. The cells are judged as the default method judges its tracks
    (:class:`flowvo.odometry.still_regions.StillRegions`, each pair one observation: its points' motion against
    their median; from ``STILL_TRACKS_FROM`` frame heights below the centre down, at half the road's share),
    widened by a cell; a pair left with too few points is dropped. ``scale_px`` as for :func:`motion_pairs`."""
    h = image_size_hw[0]
    regions = StillRegions(image_size_hw, (h - 1) / 2.0 + STILL_TRACKS_FROM * h, scale_px, STILL_SHARE / 2)
    for pair in pairs:
        regions.observe(pair.first_px, np.linalg.norm(pair.second_px - pair.first_px, axis=1))
    if not regions.still_cells:
        return pairs, 0.0
    regions.widen()
    kept = []
    for pair in pairs:
        keep = regions.keep(pair.first_px) & regions.keep(pair.second_px)
        if keep.sum() >= MIN_PAIR_POINTS:
            kept.append(PointPair(pair.first, pair.second, pair.first_px[keep], pair.second_px[keep]))
    return kept, regions.still_cells / regions.still.size
