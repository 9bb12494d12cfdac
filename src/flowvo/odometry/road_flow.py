"""The road's flow: where the road grid points of one working frame are in a later one, from the dense DIS flow
of the road crop, measured through a predicted road homography where there is one.

Pixels: the working frame's (distorted where the camera has a lens); the points given back are undistorted.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from flowvo.camera import Camera, distort_points, undistort_points
from flowvo.flow.registry import create_estimator
from flowvo.odometry.numeric import row_norms
from flowvo.odometry.road_scale import (
    GRID_MARGIN_PX,
    ROAD_CROP_HALF_WIDTH,
    ROAD_ROWS,
    horizon_below_px,
    road_crop,
    road_grid,
    road_points_in_view,
    road_top_shift_px,
)
from flowvo.odometry.still_regions import StillRegions
from flowvo.odometry.two_view import follow_flow

ROAD_WARP_INTERPOLATION = cv2.INTER_CUBIC  # how the current frame is warped onto the predicted road: bilinear
# interpolation blurs it where the prediction falls between pixels, and DIS, matching it against the sharp previous
# frame, measured 1-2 px of road flow 3.5-4.5 % long (bicubic: 2-3 %); real clips over working widths 600-640 px,
# medians 1.15 / 0.95 / 1.32 -> 1.09 / 0.88 / 1.20 % (25 of the 33 widths better); Lanczos spread clip 06 1.54x
OUTSIDE_PX = -1e4  # where a warp reads a point that has no place through the lens: far outside any frame


class RoadFlow:
    """The road crop and grid of working frames of ``working_hw`` (pixels) seen by ``camera`` (at the working
    resolution), and the dense flow (``flow_method``) that moves the grid from one frame to another; grid points in
    cells that stand still while the road moves (a bonnet) are left out (:mod:`flowvo.odometry.still_regions`:
    judged in the grid's near half, where the road moves more than its median; ``scale``: working width over the
    reference width). The crop and grid start lower for a camera pitched up or rolled so far that its horizon comes
    near the grid's top (:meth:`place`)."""

    def __init__(self, camera: Camera, working_hw: tuple[int, int], flow_method: str, scale: float = 1.0,
                 min_side_px: int = 0) -> None:
        self.camera, self.K, self.working_hw, self.scale = camera, camera.intrinsics.K, working_hw, scale
        self.min_side_px = min_side_px  # the flow's field must keep this many pixels a side (a view cut short by a
        # bonnet keeps the whole crop otherwise)
        self.estimator = create_estimator(flow_method)
        self.top_shift_px: float | None = None  # how far below a level camera's the crop and grid start
        self.place(camera.pitch_deg, camera.roll_deg)

    def place(self, pitch_deg: float, roll_deg: float = 0.0, min_side_px: int = 0) -> bool:
        """Place the crop and grid for a camera pitched ``pitch_deg`` down and rolled ``roll_deg`` (degrees; its
        mounting taken from the drive places them again) where a level camera has them, or as far below that as keeps
        the grid's top ``HORIZON_MARGIN`` of the frame's height under the horizon's lowest point across the crop
        (:func:`flowvo.odometry.road_scale.road_top_shift_px`), their still cells judged afresh where they move; False,
        and nothing moved, where the crop's smaller side would come out under ``min_side_px``."""
        horizon_px = horizon_below_px(self.K, pitch_deg, roll_deg, ROAD_CROP_HALF_WIDTH * self.working_hw[1])
        shift_px = road_top_shift_px(horizon_px, self.working_hw[0])
        if shift_px == self.top_shift_px:
            return True
        crop = road_crop(self.working_hw, self.K, top_shift_px=shift_px)
        crop_hw = (crop[0].stop - crop[0].start, crop[1].stop - crop[1].start)
        if min(crop_hw) < min_side_px:
            return False
        self.crop, self.crop_hw, self.top_shift_px = crop, crop_hw, shift_px
        self.grid_px = road_grid(self.working_hw, self.K, top_shift_px=shift_px)
        self.grid_undistorted_px = self.undistort(self.grid_px)
        self.crop_origin = np.array([self.crop[1].start, self.crop[0].start], dtype=np.float32)
        self._crop_to_frame = np.array([[1.0, 0.0, self.crop_origin[0]], [0.0, 1.0, self.crop_origin[1]],
                                        [0.0, 0.0, 1.0]])
        middle_row = self.K[1, 2] + (shift_px + self.working_hw[0] * sum(ROAD_ROWS)) / 2
        self.still = StillRegions(self.working_hw, middle_row, self.scale, cell_px=GRID_MARGIN_PX)  # a cell per grid
        # point: a bonnet's edge cuts through cells; judged from the grid's middle row down (a camera pitched up: 21
        # far points were taken for still)
        self._keep: np.ndarray | None = None  # the grid points outside the still cells (None: all)
        self._views: dict[int, RoadView] = {}
        return True

    def view(self, bottom_px: int | None = None) -> RoadView:
        """The crop and grid of frames whose view of the scene ends at row ``bottom_px`` (a bonnet found across the
        frame; None or the frame's height: none): the crop stops there, and the grid ``GRID_MARGIN_PX`` above it, as
        at the frame's bottom edge. Kept for each bottom (it changes once a drive at most)."""
        bottom_px = self.working_hw[0] if bottom_px is None else min(bottom_px, self.working_hw[0])
        if bottom_px - self.crop[0].start < self.min_side_px:
            bottom_px = self.working_hw[0]
        if bottom_px not in self._views:
            crop = (slice(self.crop[0].start, min(self.crop[0].stop, bottom_px)), self.crop[1])
            grid = self.grid_px[:, 1] < bottom_px - GRID_MARGIN_PX
            rows, columns = np.mgrid[crop[0], crop[1]]
            ideal_px = None if self.camera.distortion.is_none else \
                self.undistort(np.stack([columns.ravel(), rows.ravel()], axis=1).astype(np.float32))
            self._views[bottom_px] = RoadView(bottom_px, crop, grid, self.grid_px[grid], self.grid_undistorted_px[grid],
                                              ideal_px)
        return self._views[bottom_px]

    def from_level_top(self) -> tuple[slice, slice]:
        """The crop (rows, columns) with its top no lower than a camera mounted level has it: one told it looks up far
        enough has its crop start lower (:meth:`place`), and a still layer over the road
        (:mod:`flowvo.odometry.static_layer`) is judged over the rows between too (a windshield reflection's dots lay
        there on the real dash-cam, when a pitch told 1.8 degrees up still moved its crop down 17 px)."""
        level_top = road_crop(self.working_hw, self.K)[0].start
        return slice(min(level_top, self.crop[0].start), self.crop[0].stop), self.crop[1]

    def frame_rows(self, points_px: np.ndarray) -> np.ndarray:
        """The rows (N,) where ideal pinhole pixels (N, 2) of the working frame lie in the frame as it came, through
        the lens (the sensor's rows, as a rolling shutter reads them)."""
        return distort_points(points_px, self.K, self.camera.distortion)[:, 1]

    def undistort(self, points_px: np.ndarray) -> np.ndarray:
        """Working-frame pixels (N, 2) to ideal pinhole pixels."""
        return undistort_points(points_px, self.K, self.camera.distortion)

    def measure(self, previous: np.ndarray, current: np.ndarray, prediction: np.ndarray | None,
                unpredicted: np.ndarray | None = None, bottom_px: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The road grid points of working frame ``previous`` that stay in view, and where they are in
        ``current``, each (R, 2), undistorted working pixels (:func:`road_points_in_view`: the nearest road
        leaves the frame on a long step; ``bottom_px``: where the two frames' view ends, :meth:`view`).

        With a ``prediction`` (a road homography ``previous -> current`` on undistorted working pixels: the
        default method passes the last step's plane and motion, constant velocity, where that step found the
        road plane), the current frame is first warped onto the previous frame's road by it, and DIS
        measures only what the prediction missed: large road motion (fast driving, low frame rates) stays
        within reach of the flow, points that leave the crop are still seen, and the residual is small and
        nearly uniform, which DIS measures best. On the real clips the road step lengths against the truth
        scattered less (inter-quartile range 4.7 against 7.1 %, with dis-medium-fine) than when only road
        motion over 12 px was predicted. The homography acts on undistorted pixels; with lens
        distortion the warp goes through the lens. ``unpredicted``: :meth:`unpredicted` of the same frames where it
        was made already (without a prediction), so that DIS does not measure it twice."""
        view = self.view(bottom_px)
        moved = self._moved(previous, current, prediction, view) if unpredicted is None else unpredicted
        if self.still.observe(view.grid_px, row_norms(moved - view.grid_undistorted_px)):
            self._keep = self.still.keep(self.grid_px) if self.still.still_cells else None
        view_hw = (view.bottom_px, self.working_hw[1])
        if self._keep is None:
            return road_points_in_view(view.grid_undistorted_px, moved, view_hw)
        keep = self._keep[view.grid]
        return road_points_in_view(view.grid_undistorted_px[keep], moved[keep], view_hw)

    def unpredicted(self, previous: np.ndarray, current: np.ndarray, bottom_px: int | None = None) -> np.ndarray:
        """Where each road grid point of working frame ``previous`` in view (:meth:`view`) is in ``current`` by the
        road crop's flow without a prediction (R, 2), undistorted working pixels; nothing judged yet (:meth:`measure`
        does)."""
        return self._moved(previous, current, None, self.view(bottom_px))

    def best_prediction(self, previous: np.ndarray, current: np.ndarray, predictions: list[np.ndarray],
                        bottom_px: int | None = None) -> np.ndarray:
        """Of road homographies ``previous -> current`` (undistorted working pixels), the one whose warp of ``current``
        matches ``previous``'s road crop best (least mean absolute difference of grey levels, with the cheaper
        bilinear warp): how a drive that starts fast finds its road's motion before any prediction exists."""
        view = self.view(bottom_px)
        previous_crop = previous[view.crop].astype(np.float32)
        differences = [float(np.mean(np.abs(self._warped(current, prediction, view, cv2.INTER_LINEAR) -
                                            previous_crop))) for prediction in predictions]
        return predictions[int(np.argmin(differences))]

    def _warped(self, current: np.ndarray, prediction: np.ndarray, view: RoadView,
                interpolation: int = ROAD_WARP_INTERPOLATION) -> np.ndarray:
        """Working frame ``current`` warped onto the ``view``'s road crop by the road homography ``prediction``
        (undistorted working pixels, the crop's frame to ``current``; through the lens where the camera has one);
        what lies beyond the view's bottom row repeats it, as beyond the frame's edges."""
        current = current[: view.bottom_px]
        height, width = view.crop[0].stop - view.crop[0].start, view.crop[1].stop - view.crop[1].start
        if self.camera.distortion.is_none:
            return cv2.warpPerspective(current, prediction @ self._crop_to_frame, (width, height),
                                       flags=interpolation | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_REPLICATE)
        ideal_in_current = _transform(view.ideal_px, prediction)
        with np.errstate(over="ignore", invalid="ignore"):  # a prediction whose horizon crosses the crop sends the
            # points beyond it towards infinity, and the lens's polynomial overflows there
            source = distort_points(ideal_in_current, self.K, self.camera.distortion).astype(np.float32)
        source[~np.isfinite(source)] = OUTSIDE_PX  # outside the frame: the warp repeats its border there
        source = source.reshape(height, width, 2)
        return cv2.remap(current, source[..., 0], source[..., 1], interpolation, borderMode=cv2.BORDER_REPLICATE)

    def _moved(self, previous: np.ndarray, current: np.ndarray, prediction: np.ndarray | None, view: RoadView
               ) -> np.ndarray:
        """Where each road grid point of ``previous`` in the ``view`` is in ``current`` (R, 2), undistorted working
        pixels (see :meth:`measure`)."""
        grid = view.grid_px - self.crop_origin
        previous_crop = np.ascontiguousarray(previous[view.crop])
        if prediction is None:
            flow = self.estimator.estimate(previous_crop, np.ascontiguousarray(current[view.crop]))
            return self.undistort(follow_flow(grid, flow) + self.crop_origin)
        flow = self.estimator.estimate(previous_crop, self._warped(current, prediction, view))
        if self.camera.distortion.is_none:
            return _transform(follow_flow(grid, flow), prediction @ self._crop_to_frame)
        return _transform(self.undistort(follow_flow(grid, flow) + self.crop_origin), prediction)


@dataclass(frozen=True)
class RoadView:
    """The road crop and grid of frames whose view of the scene ends at ``bottom_px`` (:meth:`RoadFlow.view`):
    ``crop`` (rows, columns), which grid points lie in it (``grid``, (G,) bool over :attr:`RoadFlow.grid_px`) and
    those points (``grid_px``, and undistorted ``grid_undistorted_px``), and the crop's pixels undistorted
    (``ideal_px``, for the warp through a lens; None for a pinhole)."""

    bottom_px: int
    crop: tuple[slice, slice]
    grid: np.ndarray
    grid_px: np.ndarray
    grid_undistorted_px: np.ndarray
    ideal_px: np.ndarray | None


def _transform(points_px: np.ndarray, homography: np.ndarray) -> np.ndarray:
    """Points (N, 2) mapped by a 3x3 homography, float32."""
    mapped = cv2.perspectiveTransform(np.asarray(points_px, np.float64).reshape(-1, 1, 2), homography)
    return mapped.reshape(-1, 2).astype(np.float32)
