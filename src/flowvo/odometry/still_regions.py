"""Parts of the frame that do not move with the scene: a car's bonnet or dashboard in the bottom rows, a wiper at
rest, a watermark. Their points stand still while the road and the scene move, so a road plane fitted through them
tilts and the essential fit takes them for a camera that does not move; they are kept out of both.

Each cell of a grid over the working frame keeps a running mean (over the steps where the scene moved: their plain
mean at first, then exponential) of its points' motion relative to the step's median motion; a cell whose points
moved less than ``STILL_SHARE`` of it, seen in ``MIN_STEPS`` such steps at least, is still. Only cells from
``first_row`` down are judged: there the road and everything standing on it move as much as the scene (near the
horizon distant points barely move).

Pixels of the working frame (distorted, as the frames come).
"""

from __future__ import annotations

import numpy as np

from flowvo.odometry.numeric import median

CELL_PX = 16  # at the reference width: a cell of the grid
STILL_SHARE = 0.3  # a still cell's points moved less than this share of the step's median motion, on average: the
# real dash-cam's bonnet 0.18-0.27 in the road grid (whose near rows move more than its median: 0.86-1.95 on real
# KITTI 01 and 03); its tracked points 0.08-0.14 (the sky's reflections move), where the tracks of real clip 01's
# blurred verge at 13 m/s read 0.17-0.27: tracks are judged at half the share
MIN_STEPS = 8  # steps of a moving scene a cell must have been seen in before it is called still
MEMORY = 0.9  # the running mean's weight of the past per step: a car that drove ahead at the same speed and then
# pulled away frees its cells within about ten steps
MIN_SCENE_PX = 1.0  # at the reference width: a step whose points' median motion is less tells nothing (standstill)
BAND_ROW_SHARE = 0.25  # tracks: a row of cells of which this share (after the spread below still cells) stands still
# is a bonnet's or a dashboard's: the whole row is kept out. Textured points are found on a bonnet in only some of its
# cells at a time, and static points there were inliers of the essential fits while the car was slow (synthetic
# camera with a bonnet: 93 of 94 of them in the first steps), turning its rotations: r_err 0.0104 -> 0.0070 deg/m


class StillRegions:
    """The still cells of frames of ``image_hw`` (working pixels), judged from row ``first_row`` down;
    ``scale``: working width over the reference width (thresholds in pixels scale with it); ``still_share``: see
    ``STILL_SHARE``; ``cell_px``: the cells' side in working pixels (default ``CELL_PX`` scaled; the road grid's
    spacing gives each grid point a cell of its own)."""

    def __init__(self, image_hw: tuple[int, int], first_row: float, scale: float = 1.0,
                 still_share: float = STILL_SHARE, cell_px: float | None = None, band: bool = False) -> None:
        self.still_share, self.first_row, self.band = still_share, first_row, band
        self.cell_px = CELL_PX * scale if cell_px is None else cell_px
        self.min_scene_px = MIN_SCENE_PX * scale
        self.shape = (int(np.ceil(image_hw[0] / self.cell_px)), int(np.ceil(image_hw[1] / self.cell_px)))
        rows = np.arange(self.shape[0]) * self.cell_px >= first_row  # cells wholly below first_row
        self._judged = np.repeat(rows[:, None], self.shape[1], axis=1).ravel()
        self._relative = np.ones(self.shape[0] * self.shape[1])  # running mean of motion / the step's median
        self._steps = np.zeros(self.shape[0] * self.shape[1], np.int64)
        self.still = np.zeros(self.shape[0] * self.shape[1], bool)
        self.kept_out = self.still  # the cells :meth:`keep` leaves out: the still ones, and with ``band`` those below
        # them and the rows of a bonnet's band (``BAND_ROW_SHARE``)

    def _cells(self, points_px: np.ndarray) -> np.ndarray:
        rows = np.minimum(np.maximum((points_px[:, 1] // self.cell_px).astype(np.int64), 0), self.shape[0] - 1)
        columns = np.minimum(np.maximum((points_px[:, 0] // self.cell_px).astype(np.int64), 0), self.shape[1] - 1)
        return rows * self.shape[1] + columns

    def observe(self, points_px: np.ndarray, motion_px: np.ndarray) -> bool:
        """One step: points (N, 2) where they were and how far they moved (N,), pixels. Returns whether the
        still cells changed."""
        if not len(motion_px):
            return False
        scene_px = median(motion_px)
        if scene_px < self.min_scene_px:
            return False
        cells = self._cells(points_px)
        count = np.bincount(cells, minlength=self._relative.size)
        seen = count > 0
        mean = np.bincount(cells, motion_px / scene_px, minlength=self._relative.size)[seen] / count[seen]
        self._steps[seen] += 1
        weight = np.maximum(1.0 - MEMORY, 1.0 / self._steps[seen])  # the plain mean over the first steps
        self._relative[seen] = (1.0 - weight) * self._relative[seen] + weight * mean
        still = self._judged & (self._steps >= MIN_STEPS) & (self._relative < self.still_share)
        changed = bool((still != self.still).any())
        self.still = still
        if changed:
            self._keep_out_still()
        return changed

    def widen(self) -> None:
        """Take the cells next to the still ones (above, below and to each side) for still too: the edge of a
        bonnet, whose cells hold some scene as well."""
        grid = self.still.reshape(self.shape)
        wide = grid.copy()
        wide[1:] |= grid[:-1]
        wide[:-1] |= grid[1:]
        wide[:, 1:] |= grid[:, :-1]
        wide[:, :-1] |= grid[:, 1:]
        self.still = wide.ravel()
        self._keep_out_still()

    def _keep_out_still(self) -> None:
        """The cells :meth:`keep` leaves out, from the still ones (with ``band``: :func:`_band_below`)."""
        self.kept_out = _band_below(self.still, self.shape) if self.band else self.still

    def keep(self, points_px: np.ndarray) -> np.ndarray:
        """Which points (N, 2) lie outside the still cells (bool, N)."""
        if not self.kept_out.any():
            return np.ones(len(points_px), bool)
        return ~self.kept_out[self._cells(points_px)]

    def band_top_px(self) -> int | None:
        """The first pixel row of the rows kept out across the frame's whole width (with ``band``: a bonnet, a
        dashboard) that reach its bottom edge; None where the bottom row of cells is not one of them, or where every
        row is."""
        rows = self.kept_out.reshape(self.shape).all(axis=1)
        if not rows[-1] or rows.all():
            return None
        return int(np.ceil((len(rows) - int(np.argmin(rows[::-1]))) * self.cell_px))

    @property
    def still_cells(self) -> int:
        """How many cells are still now."""
        return int(self.still.sum())


def _band_below(still: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """The cells (flat, ``shape`` rows x columns) below a still cell in its column, and every cell of a row in which
    ``BAND_ROW_SHARE`` of them are (a bonnet or dashboard reaches the frame's bottom edge and spans its width)."""
    grid = np.logical_or.accumulate(still.reshape(shape), axis=0)
    grid[grid.mean(axis=1) >= BAND_ROW_SHARE] = True
    return grid.ravel()
