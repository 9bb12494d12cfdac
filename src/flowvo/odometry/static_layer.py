"""A still layer over the road: what the frames show in the same place while the road moves under it, such as a
dashboard's reflection in the windshield, dirt or a sticker on the glass. Over a dark, smooth road such a layer can
hold more of the texture than the road itself, and the road's flow, pulled towards it, stands still where the road
moves (the real dash-cam: a seam and two dots of its dashboard's reflection across the near road).

The frames' mean over the moving steps, a long exposure, holds the layer sharp while the road's texture smears along
its flow. How much of the road's texture the layer holds: the gradient energy along the flow that the long exposures
of the earlier and the later half of the frames share, over the frames' own, across the road crop. A layer's edges
count across every direction; a lane line runs along the flow and does not count; what is left of the moving road in
either half's exposure differs between the halves and cancels in the mean (a single exposure over n frames keeps
1-3.5 / n of the road's texture). Over :data:`STILL_LAYER_SHARE`, the long exposure (less its mean grey level) is
taken out of the frames the road's flow is measured on. The road's flow runs where the tracks in its part of the
frame ran, away from where the car heads (the principal point only for a camera mounted level).

Pixels of the working frame (distorted, as the frames come).
"""

from __future__ import annotations

import cv2
import numpy as np

from flowvo.odometry.numeric import row_norms

STILL_LAYER_SHARE = 0.045  # of the road's texture along the flow: over it, the layer is taken out, and it stays taken
# out while over half of it. Frames without a layer read -0.043 to 0.039 from 40 moving frames on (real KITTI 01 / 03 /
# 06 / 07 / 03 at 5 Hz, the synthetic replays of 08-10, the synthetic cameras of docs/synthetic_cameras.md, told their
# mounting or not, at 620 px and full size, seeds 3-6); the real dash-cam 0.22-0.25, a synthetic reflection added to
# real clip 01 0.05-0.07, to synthetic drives 0.07-0.13
FIRST_JUDGED_AT = 40  # moving frames: halves of 20
ENERGY_EVERY = 4  # moving frames between two samples of the frames' own gradient energy


class StaticLayer:
    """The still layer of working frames of ``image_hw`` (pixels), judged over ``region`` (rows, columns: the road
    crop as placed at the start, from no lower than a level camera's top) above row ``bonnet_from_px``, where a bonnet
    is looked for and would be still but not over the road, until the frames' view is found to end
    (:mod:`flowvo.odometry.view_bottom`), then down to where it ends: a layer over the near road above a bonnet counts
    (the real dash-cam's seam, 0.83 of the height down). The road's flow direction is the tracks' own, summed in cells
    of ``cell_px`` (a camera pitched or rolled and not told so has its flow run away from a point far from the
    principal point); cells no track started in take the direction away from ``centre_px`` (x, y). Judged at
    :data:`FIRST_JUDGED_AT` moving frames and again whenever their count doubles, so that a road key frame and the
    frame measured from it are rarely cleaned by different layers."""

    def __init__(self, image_hw: tuple[int, int], region: tuple[slice, slice], centre_px: tuple[float, float],
                 cell_px: float, bonnet_from_px: float | None = None) -> None:
        self.region = region
        self._judged_rows = self._rows_above(bonnet_from_px)  # of the region, from its top
        rows, columns = np.mgrid[region[0], region[1]].astype(np.float32)
        dx, dy = columns - centre_px[0], rows - centre_px[1]
        length = np.maximum(np.hypot(dx, dy), 1e-3)
        self._away = np.stack([dx / length, dy / length])  # (2, rows, columns): away from the centre
        self._cell_of = ((rows - region[0].start) // cell_px).astype(np.int64) * \
            int(np.ceil((region[1].stop - region[1].start) / cell_px)) + \
            ((columns - region[1].start) // cell_px).astype(np.int64)  # each pixel's cell, flat
        self._directions = np.zeros((int(self._cell_of.max()) + 1, 2))  # the tracks' unit motions, summed per cell
        self._sum = np.zeros(image_hw, np.int32)  # exact, in any order (for 8 million frames)
        self._half_sum: np.ndarray | None = None  # the sum over the first half of the frames judged next
        self._moments = np.zeros((3,) + rows.shape)  # the frames' own gx^2, gx gy, gy^2, summed
        self.frames = 0  # moving frames seen
        self._moment_frames = 0
        self._next_judged = FIRST_JUDGED_AT
        self.share: float | None = None  # the layer's share of the road's texture, once judged
        self.layer: np.ndarray | None = None  # what is taken out of the frames (float32), while the share is over
        # STILL_LAYER_SHARE
        self.removed_from: int | None = None  # the moving frame from which a layer was first taken out

    def _rows_above(self, row_px: float | None) -> int:
        """How many of the region's rows lie above frame row ``row_px`` (None: all)."""
        rows = self.region[0].stop - self.region[0].start
        return rows if row_px is None else int(np.clip(int(row_px) - self.region[0].start, 0, rows))

    def view_ends(self, bottom_px: int) -> None:
        """The frames' view ends above row ``bottom_px`` (a bonnet's edge found): the layer is judged down to it."""
        self._judged_rows = self._rows_above(bottom_px)

    def _gradients(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The gradient (x, y) over the region of ``image`` (the whole frame; float32)."""
        top = max(self.region[0].start - 1, 0)  # a row more on either side, as the whole frame's gradient has
        rows = image[top:self.region[0].stop + 1].astype(np.float32)
        inner = (slice(self.region[0].start - top, self.region[0].stop - top), self.region[1])
        return cv2.Sobel(rows, cv2.CV_32F, 1, 0, ksize=3)[inner], cv2.Sobel(rows, cv2.CV_32F, 0, 1, ksize=3)[inner]

    def observe(self, image: np.ndarray, moving: bool, points_px: np.ndarray, motion_px: np.ndarray) -> None:
        """Add a working frame (H, W, uint8) to the long exposure where the scene is ``moving`` (a standstill's
        frames would print the road sharp into it), with its tracks (``points_px`` (N, 2) where they started and
        ``motion_px`` (N, 2) how they moved, pixels) for the flow's direction, and judge the layer when due."""
        if not moving:
            return
        self._sum += image
        self.frames += 1
        columns, rows = points_px[:, 0] - self.region[1].start, points_px[:, 1] - self.region[0].start
        inside = (rows >= 0) & (rows < self._cell_of.shape[0]) & (columns >= 0) & (columns < self._cell_of.shape[1])
        lengths = row_norms(motion_px)
        inside &= lengths > 0
        units = motion_px[inside] / lengths[inside, None]
        cells = self._cell_of[rows[inside].astype(np.int64), columns[inside].astype(np.int64)]
        for axis in range(2):
            self._directions[:, axis] += np.bincount(cells, units[:, axis], minlength=len(self._directions))
        if self.frames % ENERGY_EVERY == 1:
            gx, gy = self._gradients(image)
            self._moments += np.stack([gx * gx, gx * gy, gy * gy])
            self._moment_frames += 1
        if self.frames == self._next_judged:
            self._judge()
            self._next_judged *= 2
        if 2 * self.frames == self._next_judged:
            self._half_sum = self._sum.copy()

    def _along(self) -> np.ndarray:
        """The flow's direction at each pixel of the region (2, rows, columns): its cell's tracks', or away from the
        centre where no track started."""
        norms = np.hypot(self._directions[:, 0], self._directions[:, 1])
        tracked = norms > 0
        cells = np.zeros_like(self._directions)
        cells[tracked] = self._directions[tracked] / norms[tracked, None]
        along = cells[self._cell_of].transpose(2, 0, 1)
        return np.where(tracked[self._cell_of][None], along, self._away)

    def _judge(self) -> None:
        judged = slice(0, self._judged_rows)
        ux, uy = self._along()[:, judged]
        half = self.frames / 2
        earlier = [gradient[judged] for gradient in self._gradients(self._half_sum / half)]
        later = [gradient[judged] for gradient in self._gradients((self._sum - self._half_sum) / half)]
        common = (earlier[0] * ux + earlier[1] * uy) * (later[0] * ux + later[1] * uy)
        gxx, gxy, gyy = self._moments[:, judged] / self._moment_frames
        own = float((ux * ux * gxx + 2 * ux * uy * gxy + uy * uy * gyy).sum())
        self.share = float(common.sum(dtype=np.float64) / own) if own > 0 else 0.0
        mean = (self._sum / self.frames).astype(np.float32)
        kept_from = STILL_LAYER_SHARE / 2 if self.layer is not None else STILL_LAYER_SHARE  # no flapping about it
        self.layer = mean - float(mean.mean()) if self.share > kept_from else None
        if self.layer is not None and self.removed_from is None:
            self.removed_from = self.frames

    def remove(self, image: np.ndarray) -> np.ndarray:
        """The working frame without the layer (a new array), or ``image`` itself while none is taken out."""
        if self.layer is None:
            return image
        return np.clip(np.rint(image - self.layer), 0, 255).astype(np.uint8)

    def record(self) -> dict:
        """For run.json: the layer's share of the road's texture (None: not judged, fewer moving frames than
        :data:`FIRST_JUDGED_AT`) and the moving frame from which one was taken out of the road's frames (None:
        never)."""
        return {"share": None if self.share is None else round(self.share, 4),
                "removed_from_moving_frame": self.removed_from}
