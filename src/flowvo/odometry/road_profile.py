"""Where the ground around the camera is level with the road under it: cells of the road grid's ground (by depth
and sideways, in camera heights) whose points stand persistently above or below the trusted road planes are left
out of the plane fit.

The road grid spans a fixed share of the frame's width, so 20 m ahead it reaches 6-7 m to each side: kerbs,
verges, pavements and parked cars. On every real KITTI clip the points beyond 1.5-2 camera heights sideways stand
3-30 % of the height above the plane through the road under the car (the median over a drive, growing with the
distance to the side), and on 03 the road beyond 14 heights ahead 2-25 %; on the synthetic roads the sides stand
within 2 % but for pavements and hills far ahead. Ground above the road far ahead tilts the fitted plane up ahead,
so the plane's distance (the camera height in units of the step) comes out long and the step short: real 03's
path ran 1.0 % short. Each trusted plane's points give one median residual per cell; a cell whose median over the
last ``PROFILE_STEPS`` steps it was seen in lies beyond ``OFF_ROAD_SHARE`` of the height, once it was seen in
``MIN_CELL_STEPS`` steps, is off the road until its median comes back.

Frames: the frame the road plane is fitted in (the road-levelled camera frame: x right, y down, z forward);
points and plane distances in one unit (the step's length); cells in camera heights (the plane's distance).
"""

from __future__ import annotations

import numpy as np

from flowvo.odometry.numeric import median
from flowvo.odometry.road_plane import MIN_ROAD_POINTS, RoadPlane

DEPTH_EDGES_H = np.array([5.0, 7.0, 10.0, 14.0, 20.0])  # the cells' depth bands (camera heights ahead; below the
# first and beyond the last: one band each), about 1.4 times deeper each
SIDE_CELL_H = 0.5  # the cells' width sideways, camera heights (0.8 m at 1.65 m)
SIDE_REACH_H = 5.0  # cells beyond this far to the side (camera heights) share one cell each side
OFF_ROAD_SHARE = 0.02  # a cell whose median residual lies further from the plane (share of the height: 3.3 cm at
# 1.65 m) is not the road's surface. t_err % on real 03 / 03 at 5 Hz / 01: 1.11 / 1.35 / 1.10 with every cell, 0.88 /
# 0.89 / 1.07 at 1.5 %, 0.91 / 1.01 / 1.06 at 2 %, 0.93 / 0.97 / 1.08 at 3 %
PROFILE_STEPS = 100  # the steps a cell was seen in that its median spans
MIN_CELL_STEPS = 20  # steps a cell must be seen in before it is judged
MIN_CELL_POINTS = 5  # points of one step a cell needs for that step's median

FAR_ROAD_H = (10.0, 20.0)  # the road straight ahead this far (camera heights) tells whether the road points lie on a
# plane at all: real KITTI's within 1.4-2.4 % of the height of the plane through the near road; the real dash-cam's
# 18-35 % below it while its noisy road flow was measured over one step, 3 % over the baseline its noise needs
# (flowvo.odometry.road_noise, docs/dashcam.md)
AHEAD_H = 1.0  # "straight ahead": cells within this far to a side (camera heights)
FAR_ROAD_WARNING_SHARE = 0.10  # farther off the plane than this, the road is not a plane to the method (flowvo run
# warns): real KITTI 01 / 03 / 06 / 07 read -0.000 / -0.035 / -0.001 / -0.016, the real dash-cam +0.028 (+0.21 over
# one step's baseline)

SIDE_EDGES_H = np.arange(-SIDE_REACH_H, SIDE_REACH_H + SIDE_CELL_H / 2, SIDE_CELL_H)
CELLS = (len(DEPTH_EDGES_H) + 1) * (len(SIDE_EDGES_H) + 1)
_depth_low = np.r_[0.0, DEPTH_EDGES_H].repeat(len(SIDE_EDGES_H) + 1)
_depth_high = np.r_[DEPTH_EDGES_H, np.inf].repeat(len(SIDE_EDGES_H) + 1)
_side_low = np.tile(np.r_[-np.inf, SIDE_EDGES_H], len(DEPTH_EDGES_H) + 1)
_side_high = np.tile(np.r_[SIDE_EDGES_H, np.inf], len(DEPTH_EDGES_H) + 1)
FAR_AHEAD_CELLS = (_depth_low >= FAR_ROAD_H[0]) & (_depth_high <= FAR_ROAD_H[1]) & (_side_low >= -AHEAD_H) & \
    (_side_high <= AHEAD_H)


def ground_cells(points: np.ndarray, height: float) -> np.ndarray:
    """The cell index (N,) of each point (N, 3) for a road ``height`` below the camera (same unit)."""
    depth = np.searchsorted(DEPTH_EDGES_H, points[:, 2] / height)
    side = np.searchsorted(SIDE_EDGES_H, points[:, 0] / height)
    return depth * (len(SIDE_EDGES_H) + 1) + side


def road_residuals(points: np.ndarray, plane: RoadPlane) -> np.ndarray:
    """How far each point (N, 3) lies below ``plane`` (N,), a share of the plane's distance (negative: above it)."""
    return points @ plane.normal / plane.distance - 1.0


def cell_medians(residuals: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """The median of ``residuals`` (N,) in each of the ``CELLS`` cells (``cells`` (N,): each one's index), NaN where
    a cell holds fewer than ``MIN_CELL_POINTS`` (sorted once: no loop over the cells)."""
    by_residual = np.argsort(residuals)  # then by cell, stable (a radix sort of 16-bit cells): the residuals
    # in np.lexsort's order, at a third of its cost
    ordered = residuals[by_residual][np.argsort(cells[by_residual].astype(np.int16), kind="stable")]
    counts = np.bincount(cells, minlength=CELLS)
    starts = np.cumsum(counts) - counts
    medians = np.full(CELLS, np.nan)
    full = counts >= MIN_CELL_POINTS
    low, high = starts[full] + (counts[full] - 1) // 2, starts[full] + counts[full] // 2
    medians[full] = (ordered[low] + ordered[high]) / 2
    return medians


class RoadProfile:
    """The cells of the ground that are not the road's surface (module docstring): :meth:`keep` says which points a
    plane fit takes, :meth:`observe` learns from each trusted plane, :meth:`forget` starts afresh (the frame the planes
    are fitted in turned: a mounting taken from the drive)."""

    def __init__(self) -> None:
        self._medians = np.full((PROFILE_STEPS, CELLS), np.nan)  # each cell's median residual in its last steps seen
        self._seen = np.zeros(CELLS, np.int64)  # steps each cell was seen in
        self.off_road = np.zeros(CELLS, bool)
        self.medians = np.full(CELLS, np.nan)  # each judged cell's median residual (share of the height; NaN: not)

    def keep(self, points: np.ndarray) -> np.ndarray:
        """Which of the candidate road points (N, 3) a plane fit takes: those outside the cells off the road, or all
        where fewer than ``MIN_ROAD_POINTS`` would be left. The height is the points' median depth below the camera."""
        if not self.off_road.any() or not len(points):
            return np.ones(len(points), bool)
        kept = ~self.off_road[ground_cells(points, median(points[:, 1]))]
        return kept if kept.sum() >= MIN_ROAD_POINTS else np.ones(len(points), bool)

    def observe(self, points: np.ndarray, plane: RoadPlane, residuals: np.ndarray | None = None) -> None:
        """Learn from a trusted ``plane`` (the fit's frame) and every candidate point (N, 3) it was fitted among
        (``residuals``: their :func:`road_residuals`, where the caller has them already)."""
        if plane.distance <= 0 or not len(points):
            return
        residuals = road_residuals(points, plane) if residuals is None else residuals
        medians = cell_medians(residuals, ground_cells(points, plane.distance))
        cells = np.flatnonzero(~np.isnan(medians))
        self._medians[self._seen[cells] % PROFILE_STEPS, cells] = medians[cells]
        self._seen[cells] += 1
        judged = self._seen >= MIN_CELL_STEPS
        if judged.any():  # each judged cell's median over its steps seen (the NaNs of unfilled rows sort last)
            ordered = np.sort(self._medians[:, judged], axis=0)
            count, columns = np.minimum(self._seen[judged], PROFILE_STEPS), np.arange(judged.sum())
            self.medians[judged] = (ordered[(count - 1) // 2, columns] + ordered[count // 2, columns]) / 2
        self.off_road[:] = np.abs(self.medians) > OFF_ROAD_SHARE  # a NaN (not judged) is not off the road

    def forget(self) -> None:
        """Start afresh: nothing is off the road until cells are judged again."""
        self._medians[:] = np.nan
        self._seen[:] = 0
        self.off_road[:] = False
        self.medians[:] = np.nan

    def far_road_share(self) -> float | None:
        """How far the road straight ahead at ``FAR_ROAD_H`` lies off the trusted planes (the median of its judged
        cells, share of the height, positive below), or None before any is judged."""
        far = self.medians[FAR_AHEAD_CELLS]
        far = far[~np.isnan(far)]
        return float(np.median(far)) if len(far) else None

    def record(self) -> dict:
        """What ``run.json`` records: the cells left out at the end, and :meth:`far_road_share`."""
        far = self.far_road_share()
        return {"ground_cells_off_road": int(self.off_road.sum()),
                "far_road_off_plane_share": None if far is None else round(far, 4)}
