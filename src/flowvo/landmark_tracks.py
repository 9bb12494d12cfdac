"""Points tracked over many frames, for the bundle adjustment (:mod:`flowvo.bundle_window`).

Each frame, every live track is followed into the new frame by pyramidal Lucas-Kanade, checked forward and
backward; a track that fails or leaves the frame ends. New tracks start from the frame's textured points where
no live track lies within ``spacing_px``, up to ``max_tracks`` in all, so the tracks stay spread over the frame.
Every track has an id that never repeats within a drive.

Pixels of the (distorted) working frame; the caller removes the lens.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from flowvo.two_view import track_points_checked

MAX_TRACKS = 240  # live tracks at most (every frame adds new ones up to this)
SPACING_PX = 16.0  # at the reference width: a new track starts this far from any live one at least
RETURN_PX = 0.5  # at the reference width: the backward track returns this close to the start, or the track ends


class Landmarks(NamedTuple):
    """The tracks seen in one frame: ``ids`` (M,) int64 and where each is, ``px`` (M, 2) float32."""

    ids: np.ndarray
    px: np.ndarray


class LandmarkTracker:
    """Live tracks from frame to frame (see the module docstring); ``advance`` once per frame, in order."""

    def __init__(self, spacing_px: float = SPACING_PX, return_px: float = RETURN_PX,
                 max_tracks: int = MAX_TRACKS) -> None:
        self.spacing_px, self.return_px, self.max_tracks = spacing_px, return_px, max_tracks
        self._live = Landmarks(np.zeros(0, np.int64), np.zeros((0, 2), np.float32))
        self._previous: np.ndarray | None = None
        self._next_id = 0

    def advance(self, image: np.ndarray, textured_px: np.ndarray) -> Landmarks:
        """The tracks in ``image`` (grey, the next frame): the live ones followed from the last frame, and new
        ones from ``textured_px`` (N, 2) where the frame has room for them."""
        ids, px = self._live
        if self._previous is not None and len(px):
            moved, kept = track_points_checked(self._previous, image, px, self.return_px)
            height, width = image.shape[:2]
            kept &= (moved[:, 0] >= 0) & (moved[:, 1] >= 0) & (moved[:, 0] <= width - 1) & (moved[:, 1] <= height - 1)
            ids, px = ids[kept], moved[kept]
        fresh = _uncovered(np.asarray(textured_px, np.float32).reshape(-1, 2), px, self.spacing_px)
        fresh = fresh[:max(self.max_tracks - len(px), 0)]
        new_ids = np.arange(self._next_id, self._next_id + len(fresh), dtype=np.int64)
        self._next_id += len(fresh)
        self._live = Landmarks(np.concatenate([ids, new_ids]), np.concatenate([px, fresh]).astype(np.float32))
        self._previous = image
        return self._live


def _uncovered(candidates_px: np.ndarray, covered_px: np.ndarray, spacing_px: float) -> np.ndarray:
    """The candidates (N, 2) in cells of ``spacing_px`` that hold no covered point (M, 2), one per cell."""
    def cells(points: np.ndarray) -> np.ndarray:
        column_row = np.floor(points / spacing_px).astype(np.int64)
        return column_row[:, 0] * 1_000_003 + column_row[:, 1]

    candidate_cells = cells(candidates_px)
    free = ~np.isin(candidate_cells, cells(covered_px))
    _, first = np.unique(candidate_cells[free], return_index=True)
    return candidates_px[free][np.sort(first)]
