"""Points tracked over many frames, for the bundle adjustment (:mod:`flowvo.odometry.bundle_window`).

Each frame, every live track is followed into the new frame by pyramidal Lucas-Kanade, checked forward and
backward, and then measured again from the frame it started in, searched from there: a position chained from
frame to frame gathers every step's error, one measured from the track's first frame only one. A track ends when
it fails, leaves the frame, its two positions lie more than ``agree_px`` apart, or ``max_age`` frames after it
started.
New tracks start from the frame's textured points where no live track lies within ``spacing_px``, up to
``max_tracks`` in all, so the tracks stay spread over the frame. Every track has an id that never repeats within a
drive.

Pixels of the (distorted) working frame; the caller removes the lens.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from flowvo.odometry.two_view import lucas_kanade, track_points_checked

MAX_TRACKS = 240  # live tracks at most (every frame adds new ones up to this)
SPACING_PX = 16.0  # at the reference width: a new track starts this far from any live one at least
RETURN_PX = 0.5  # at the reference width: the backward track returns this close to the start, or the track ends
AGREE_PX = 1.0  # at the reference width: chained and measured from its first frame, a track agrees this well
MAX_AGE = 10  # frames: a track is followed this many frames after it started at most (the bundle window's; with the
# bundle's own rotations, chained tracks of any age against these: real clip 01 0.0072 -> 0.0048 deg/m, 1.03 -> 1.01 %)
FIRST_FRAME_LEVELS = 1  # pyramid levels above the frame when measuring from the first frame (the search starts close)


class Landmarks(NamedTuple):
    """The tracks seen in one frame: ``ids`` (M,) int64 and where each is, ``px`` (M, 2) float32."""

    ids: np.ndarray
    px: np.ndarray


class LandmarkTracker:
    """Live tracks from frame to frame (see the module docstring); ``advance`` once per frame, in order."""

    def __init__(self, spacing_px: float = SPACING_PX, return_px: float = RETURN_PX, agree_px: float = AGREE_PX,
                 max_tracks: int = MAX_TRACKS, max_age: int = MAX_AGE) -> None:
        self.spacing_px, self.return_px, self.agree_px = spacing_px, return_px, agree_px
        self.max_tracks, self.max_age = max_tracks, max_age
        self._live = Landmarks(np.zeros(0, np.int64), np.zeros((0, 2), np.float32))
        self._born = np.zeros(0, np.int64)  # the frame each live track started in
        self._first_frames: dict[int, tuple[np.ndarray, Landmarks]] = {}  # frame -> (image, the tracks started there)
        self._previous: np.ndarray | None = None
        self._frame = -1
        self._next_id = 0

    def advance(self, image: np.ndarray, textured_px: np.ndarray) -> Landmarks:
        """The tracks in ``image`` (grey, the next frame): the live ones followed from the last frame, and new
        ones from ``textured_px`` (N, 2) where the frame has room for them."""
        self._frame += 1
        (ids, px), born = self._live, self._born
        if self._previous is not None and len(px):
            moved, kept = track_points_checked(self._previous, image, px, self.return_px)
            height, width = image.shape[:2]
            kept &= (moved[:, 0] >= 0) & (moved[:, 1] >= 0) & (moved[:, 0] <= width - 1) & (moved[:, 1] <= height - 1)
            kept &= self._frame - born <= self.max_age
            for first in np.unique(born[kept]).tolist():
                rows = np.flatnonzero(kept & (born == first))
                first_image, started = self._first_frames[first]
                start_px = started.px[np.searchsorted(started.ids, ids[rows])]
                measured, found = lucas_kanade(first_image, image, start_px, guess_px=moved[rows],
                                               levels=FIRST_FRAME_LEVELS)
                agree = found & (np.linalg.norm(measured - moved[rows], axis=1) <= self.agree_px)
                moved[rows[agree]] = measured[agree]
                kept[rows[~agree]] = False
            ids, px, born = ids[kept], moved[kept], born[kept]
        fresh = _uncovered(np.asarray(textured_px, np.float32).reshape(-1, 2), px, self.spacing_px)
        fresh = fresh[:max(self.max_tracks - len(px), 0)]
        new_ids = np.arange(self._next_id, self._next_id + len(fresh), dtype=np.int64)
        self._next_id += len(fresh)
        self._first_frames[self._frame] = (image, Landmarks(new_ids, fresh))
        self._first_frames.pop(self._frame - self.max_age - 1, None)
        self._live = Landmarks(np.concatenate([ids, new_ids]), np.concatenate([px, fresh]).astype(np.float32))
        self._born = np.concatenate([born, np.full(len(new_ids), self._frame)])
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
