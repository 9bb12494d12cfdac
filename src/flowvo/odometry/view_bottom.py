"""Where a frame's view of the scene ends: the top edge of a bonnet or dashboard across its bottom rows.

Road points that move under a bonnet during a step are tracked into its paint, where a frame's bottom edge would lose
them; a view that ends at the bonnet's edge loses them alike. The still tracks (:mod:`flowvo.odometry.still_regions`)
tell that a band stands still across the bottom rows, to a cell. The edge is then placed to the row in the frames'
mean image, where the moving scene blurs and the still edge stays sharp: in each of the middle half of the columns,
the row of the steepest vertical change of grey level, their median (synthetic bonnets: the row itself; the real
dash-cam: 323-324 of 349). The view ends a row above it, so that no row of paint is left (3 rows left in view cost more
than the cut gained; a cut 5 rows too high lost as much). Found once, it stays: a bonnet does not leave. A car that
fills the bottom rows across a quarter of the width at the same speed long enough to be judged still (8 moving steps)
would end the view for the rest of the drive too (not seen on any drive here; the cells below the cut are no longer
observed, so nothing tells that it left).

Pixels of the working frame (distorted, as the frames come); rows from the top.
"""

from __future__ import annotations

import cv2
import numpy as np


class ViewBottom:
    """The row where frames of ``image_hw`` (working pixels) stop showing the scene (:attr:`bottom_px`, the frames'
    height until a band is found), searched from row ``first_row`` down; ``cell_px``: the still tracks' cell side,
    within which their band's top tells the edge."""

    def __init__(self, image_hw: tuple[int, int], first_row: float, cell_px: float) -> None:
        self.first_row, self.cell_px, self.height_px = int(first_row), cell_px, image_hw[0]
        self.bottom_px = image_hw[0]
        self.found = False
        self._sum = np.zeros((max(image_hw[0] - self.first_row, 0), image_hw[1]), np.float64)
        self._frames = 0

    def observe(self, image: np.ndarray) -> None:
        """Add a working frame (H, W, uint8) to the mean image, until the edge is found."""
        if not self.found:
            self._sum += image[self.first_row:]
            self._frames += 1

    def settle(self, band_top_px: int | None) -> int:
        """The view's bottom row now: where the still tracks first show a band from ``band_top_px`` (pixels; None:
        none) to the frames' bottom, the mean image's edge within a cell of that row places it, for good."""
        if self.found or band_top_px is None or not self._frames:
            return self.bottom_px
        top = max(int(band_top_px - 2 * self.cell_px) - self.first_row, 1)
        stop = min(int(band_top_px + self.cell_px) - self.first_row, self._sum.shape[0] - 1)
        if stop - top < 2:
            return self.bottom_px
        mean = (self._sum / self._frames).astype(np.float32)
        width = mean.shape[1]
        steepness = np.abs(cv2.Sobel(mean, cv2.CV_32F, 0, 1, ksize=3))[top:stop, width // 4: 3 * width // 4]
        edge = self.first_row + top + int(np.median(np.argmax(steepness, axis=0)))
        self.bottom_px, self.found = edge - 1, True
        self._sum = self._sum[:0]
        return self.bottom_px

    def frame_row(self, frame_rows: int) -> int | None:
        """Where the view ends in frames ``frame_rows`` high (the working frame's row scaled to them; None: nothing
        found, the view is the whole frame)."""
        return round(self.bottom_px * frame_rows / self.height_px) if self.found else None
