"""The procedural world around a camera path: terrain, road, scene types and box-shaped objects.

World frame = KITTI world (x right, y down, z forward of the first camera), metres. The ground follows
the path (the camera height below it, KITTI's 1.65 m by default) and undulates gently away from it; the
road is a band around the path.
Objects (facades, walls, houses, trees, poles) are boxes that never intrude on the road.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from flowvo.camera import KITTI_CAMERA_HEIGHT_M
from flowvo.synth.sampling import sample_points

GRID_RESOLUTION_M = 0.5
GRID_MARGIN_M = 160.0
GRADE_SPAN_M = 4.0  # the road's grade is its rise over this much path
SCENE_TYPES = ("urban", "suburban", "open")
ROAD_HALF_WIDTH_M = {"urban": 5.0, "suburban": 4.0, "open": 7.5}
SCENE_BRIGHTNESS = {"urban": 0.85, "suburban": 1.0, "open": 1.12}


@dataclass(frozen=True)
class Boxes:
    """N boxes: centre of the base (x, z), base height y (down), yaw (rad, like a camera heading),
    half extents along / across (m), height (m), texture name, texture offset (m), brightness."""

    centre_xz: np.ndarray
    base_y: np.ndarray
    yaw: np.ndarray
    half_along: np.ndarray
    half_across: np.ndarray
    height: np.ndarray
    texture: tuple[str, ...]
    texture_offset: np.ndarray
    brightness: np.ndarray

    def __len__(self) -> int:
        return len(self.base_y)


@dataclass(frozen=True)
class World:
    """Terrain and road grids (rows = z, cols = x, 0.5 m cells) plus objects and scene schedule."""

    origin_xz: np.ndarray
    ground_y: np.ndarray
    lateral_m: np.ndarray
    along_m: np.ndarray
    scene_index: np.ndarray
    boxes: Boxes
    seed: int

    def grid_coords(self, x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Fractional (col, row) grid coordinates of world points, float32."""
        col = ((x - self.origin_xz[0]) / GRID_RESOLUTION_M).astype(np.float32)
        row = ((z - self.origin_xz[1]) / GRID_RESOLUTION_M).astype(np.float32)
        return col, row

    def lookup(self, grid: np.ndarray, x: np.ndarray, z: np.ndarray, nearest: bool = False) -> np.ndarray:
        """Bilinear (or nearest) lookup of a grid at world points, clamped at the border."""
        col, row = self.grid_coords(x, z)
        return sample_points(grid, col, row, cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR)


def scene_schedule(seed: int, length_m: float, scene: str | None) -> tuple[np.ndarray, np.ndarray]:
    """Arclength starts (m) and scene-type indices of consecutive stretches of 150..450 m."""
    if scene is not None:
        return np.array([0.0]), np.array([SCENE_TYPES.index(scene)])
    rng = np.random.default_rng(seed + 7)
    starts, kinds, s = [], [], 0.0
    kind = int(rng.integers(3))
    while s <= length_m:
        starts.append(s)
        kinds.append(kind)
        s += rng.uniform(150.0, 450.0)
        kind = (kind + int(rng.integers(1, 3))) % 3
    return np.asarray(starts), np.asarray(kinds)


def _resample_path(positions: np.ndarray, spacing_m: float) -> tuple[np.ndarray, np.ndarray]:
    steps = np.linalg.norm(np.diff(positions[:, [0, 2]], axis=0), axis=1)
    arclength = np.concatenate([[0.0], np.cumsum(steps)])
    keep = np.concatenate([[True], steps > 1e-6])
    arclength, positions = arclength[keep], positions[keep]
    if arclength[-1] < spacing_m:  # parked, or barely moving (2 frames from a standstill): extend a 1 m
        # stub forward, along the motion if any, so the road has a direction and at least two samples
        heading = positions[-1] - positions[0]
        heading[1] = 0.0
        norm = np.linalg.norm(heading)
        heading = heading / norm if norm > 1e-6 else np.array([0.0, 0.0, 1.0])
        positions = np.stack([positions[0], positions[0] + max(spacing_m, 1.0) * heading])
        arclength = np.array([0.0, max(spacing_m, 1.0)])
    samples = np.arange(0.0, arclength[-1] + 1e-9, spacing_m)
    resampled = np.stack([np.interp(samples, arclength, positions[:, k]) for k in range(3)], 1)
    return samples, resampled


def _height_along_path(along_m: np.ndarray, along: np.ndarray, heights_y: np.ndarray) -> np.ndarray:
    """The path's height (world y, down, metres) at arclengths ``along_m`` of the path sampled at arclengths
    ``along`` (increasing from 0) with heights ``heights_y``: interpolated along it, and beyond either end continued at
    the grade of its first or last ``GRADE_SPAN_M``. A road does not end where a drive does: held level there, the
    road ahead of the synthetic replay of KITTI 03, which stops on a climb of 5.8 degrees, bent down by as much
    under the last 60 frames' view; their road planes were refused as tilted, and over three worlds the last 50
    frames read 0.985 / 1.068 / 1.174 of their length (now 1.020-1.033)."""
    inside = np.interp(along_m, along, heights_y)
    ends = np.clip([along[0], along[0] + GRADE_SPAN_M, along[-1] - GRADE_SPAN_M, along[-1]], along[0], along[-1])
    first, second, before_last, last = np.interp(ends, along, heights_y)
    span_m = np.maximum([ends[1] - ends[0], ends[3] - ends[2]], 1e-9)
    start_grade, end_grade = (second - first) / span_m[0], (last - before_last) / span_m[1]
    return inside + np.minimum(along_m - along[0], 0.0) * start_grade + np.maximum(along_m - along[-1], 0.0) * end_grade


def build_world(T_world_cam: np.ndarray, seed: int, scene: str | None = None,
                camera_height_m: float = KITTI_CAMERA_HEIGHT_M) -> World:
    """The world for a camera path (N, 4, 4) whose camera rides ``camera_height_m`` above the road,
    deterministic per seed."""
    along, path = _resample_path(T_world_cam[:, :3, 3], GRID_RESOLUTION_M / 2)
    tangent = np.gradient(path[:, [0, 2]], axis=0)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-9)
    lo = path[:, [0, 2]].min(0) - GRID_MARGIN_M
    hi = path[:, [0, 2]].max(0) + GRID_MARGIN_M
    shape = tuple(np.ceil((hi - lo) / GRID_RESOLUTION_M).astype(int)[::-1] + 1)
    cells = np.round((path[:, [0, 2]] - lo) / GRID_RESOLUTION_M).astype(int)
    owner = np.full(shape, -1, np.int64)
    owner[cells[:, 1], cells[:, 0]] = np.arange(len(path))
    source = np.where(owner >= 0, 0, 255).astype(np.uint8)
    _, labels = cv2.distanceTransformWithLabels(source, cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL)
    zero_rows, zero_cols = np.nonzero(source == 0)
    nearest = owner[zero_rows, zero_cols][labels - 1]
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    cell_x = lo[0] + cols * GRID_RESOLUTION_M
    cell_z = lo[1] + rows * GRID_RESOLUTION_M
    dx, dz = cell_x - path[nearest, 0], cell_z - path[nearest, 2]
    lateral = (tangent[nearest, 1] * dx - tangent[nearest, 0] * dz).astype(np.float32)  # + = right of path
    along_grid = (along[nearest] + tangent[nearest, 0] * dx + tangent[nearest, 1] * dz).astype(np.float32)
    rng = np.random.default_rng(seed)
    beyond = (along_grid < along[0]) | (along_grid > along[-1])  # the road goes on straight before and after the
    # drive, as its objects do (_frame_at)
    distance = np.where(beyond, np.abs(lateral), np.hypot(dx, dz))  # from the road, where the hills start
    undulation = 2.5 * cv2.GaussianBlur(rng.normal(size=shape).astype(np.float32), (0, 0), 60.0)
    undulation /= max(float(np.abs(undulation).max()), 1e-6) / 3.0
    blend = np.clip((distance - 12.0) / 60.0, 0.0, 1.0)
    # the road's height at each cell's own place along the path (its nearest sample lies up to a cell away: on a
    # grade the road was off by that), the camera camera_height_m above it along the road's normal: on a grade g,
    # sqrt(1 + g^2) times as far straight down (the grade over 4 m of path)
    road_y = _height_along_path(along_grid, along, path[:, 1])
    grade = (_height_along_path(along_grid + GRADE_SPAN_M / 2, along, path[:, 1])
             - _height_along_path(along_grid - GRADE_SPAN_M / 2, along, path[:, 1])) / GRADE_SPAN_M
    ground = road_y + camera_height_m * np.sqrt(1.0 + grade**2) - blend * undulation  # hills rise away from the road
    ground = cv2.GaussianBlur(ground.astype(np.float32), (0, 0), 2.0)
    starts, kinds = scene_schedule(seed, along[-1], scene)
    scene_index = kinds[np.searchsorted(starts, along_grid, side="right").clip(1) - 1].astype(np.float32)
    world = World(lo, ground, lateral, along_grid, scene_index, Boxes(*_empty_boxes()), seed)
    boxes = _place_objects(world, along, path, tangent, starts, kinds, rng)
    return World(lo, ground, lateral, along_grid, scene_index, boxes, seed)


def _empty_boxes() -> tuple:
    empty = np.zeros(0)
    return np.zeros((0, 2)), empty, empty, empty, empty, empty, (), empty, empty


def _place_objects(world, along, path, tangent, starts, kinds, rng) -> Boxes:
    records: list[tuple] = []
    for side in (-1.0, 1.0):
        s = rng.uniform(0.0, 10.0)
        while s < along[-1] + 60.0:
            kind = SCENE_TYPES[kinds[np.searchsorted(starts, s, side="right") - 1]]
            half_road = ROAD_HALF_WIDTH_M[kind]
            if kind == "urban":
                length, depth = rng.uniform(10, 28), rng.uniform(8, 14)
                offset = half_road + rng.uniform(1.5, 4.0) + depth / 2
                height, texture, gap = rng.uniform(8, 24), str(rng.choice(["facade", "brick"])), rng.uniform(0, 3)
            elif kind == "suburban":
                if rng.random() < 0.5:
                    length, depth = rng.uniform(7, 13), rng.uniform(7, 10)
                    offset = half_road + rng.uniform(5, 14) + depth / 2
                    height, texture, gap = rng.uniform(4, 8), str(rng.choice(["facade", "brick"])), rng.uniform(4, 12)
                else:
                    records += _tree(path, tangent, along, s, side, half_road + rng.uniform(2, 6), rng)
                    s += rng.uniform(6, 14)
                    continue
            else:
                if rng.random() < 0.6:
                    length, depth, offset = 0.25, 0.25, half_road + 2.0
                    height, texture, gap = 8.0, "bark", 40.0
                else:
                    records += _tree(path, tangent, along, s, side, half_road + rng.uniform(4, 30), rng)
                    s += rng.uniform(15, 60)
                    continue
            centre_s, lateral = s + length / 2, side * offset
            records.append(_box_at(path, tangent, along, centre_s, lateral, length, depth, height, texture, rng))
            s += length + gap
    records = [_seat_on_ground(world, r) for r in records if _clear_of_road(world, r)]
    if not records:
        return Boxes(*_empty_boxes())
    columns = list(zip(*records, strict=True))
    return Boxes(
        np.asarray(columns[0]), *(np.asarray(c, dtype=np.float64) for c in columns[1:6]),
        tuple(columns[6]), np.asarray(columns[7]), np.asarray(columns[8]),
    )


def _frame_at(path, tangent, along, s):
    index = int(np.clip(np.searchsorted(along, s), 0, len(along) - 1))
    if s <= along[-1]:
        return path[index, [0, 2]], tangent[index]
    return path[-1, [0, 2]] + tangent[-1] * (s - along[-1]), tangent[-1]


def _box_at(path, tangent, along, s, lateral, length, depth, height, texture, rng) -> tuple:
    point, direction = _frame_at(path, tangent, along, s)
    right = np.array([direction[1], -direction[0]])
    centre = point + lateral * right
    yaw = float(np.arctan2(direction[0], direction[1]))
    return (centre, 0.0, yaw, length / 2, depth / 2, height, texture, rng.uniform(0, 50), rng.uniform(0.8, 1.15))


def _tree(path, tangent, along, s, side, lateral, rng) -> list[tuple]:
    trunk_h = rng.uniform(1.8, 3.0)
    crown = rng.uniform(2.5, 5.0)
    trunk = _box_at(path, tangent, along, s, side * lateral, 0.4, 0.4, trunk_h + 0.5, "bark", rng)
    top = _box_at(path, tangent, along, s, side * lateral, crown, crown, crown, "foliage", rng)
    return [trunk, top[:1] + (-trunk_h,) + top[2:]]


def _footprint_points(record: tuple) -> np.ndarray:
    centre, yaw, half_along, half_across = record[0], record[2], record[3], record[4]
    forward = np.array([np.sin(yaw), np.cos(yaw)])
    right = np.array([forward[1], -forward[0]])
    u = np.linspace(-1, 1, 5)
    edges = [(a, b) for a in u for b in (-1, 1)] + [(a, b) for a in (-1, 1) for b in u]
    return np.array([centre + a * half_along * forward + b * half_across * right for a, b in edges])


def _clear_of_road(world: World, record: tuple) -> bool:
    """True when no point of the box footprint is within 1 m of any road."""
    points = _footprint_points(record)
    lateral = world.lookup(world.lateral_m, points[:, 0], points[:, 1])
    scene = world.lookup(world.scene_index, points[:, 0], points[:, 1], nearest=True).astype(int)
    half_road = np.array([ROAD_HALF_WIDTH_M[SCENE_TYPES[k]] for k in scene])
    return bool(np.all(np.abs(lateral) > half_road + 1.0))


def _seat_on_ground(world: World, record: tuple) -> tuple:
    """Set the base height: 0.5 m into the ground at the lowest corner (no gap on slopes), or, for a
    lifted box (a tree crown), ``lift`` above the ground at its centre."""
    centre, lift, height = record[0], record[1], record[5]
    if lift == 0.0:
        points = _footprint_points(record)
        base = float(world.lookup(world.ground_y, points[:, 0], points[:, 1]).max()) + 0.5
        return (centre, base, *record[2:5], height + 0.5, *record[6:])
    base = float(world.lookup(world.ground_y, centre[:1], centre[1:])[0]) + lift
    return (centre, base, *record[2:])
