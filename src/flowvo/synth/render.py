"""Vectorised ray casting of a :class:`World` through a pinhole camera, optionally behind a lens.

Geometry pass: the terrain by Newton and secant steps of the ray-heightfield intersection from the ground's plane
under the camera (rays they miss marched to the ground), boxes as quads rasterised inside their projected
bounding boxes with a z-buffer. Shading pass: one texture lookup per material for all its pixels. Depth is the z
coordinate in the camera frame (metres), ``inf`` for the sky. A rolling shutter's frame is rendered in bands of rows,
each from the camera's pose when its middle row is exposed (:func:`render_rolling_shutter`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flowvo.camera import NO_DISTORTION, LensDistortion, undistort_points
from flowvo.synth.textures import Texture
from flowvo.synth.world import ROAD_HALF_WIDTH_M, SCENE_BRIGHTNESS, SCENE_TYPES, World

MAX_DEPTH_M = 400.0
NEAR_M = 0.3
OBJECT_RANGE_M = 300.0
TERRAIN_ITERATIONS = 6  # Newton steps towards the ground (the slope of the ground's plane under the camera), then
# secant steps
SECANT_STEPS = 3
HIT_TOLERANCE_M = 0.001  # a ray within this of the ground (plus 1e-5 of its depth) has reached it: a ray grazing
# the road 50 m ahead falls 3 cm a metre relative to it, so the depth is then within 5 cm
MARCH_GROWTH = 1.15  # the rays missed are marched in steps 15 % longer each (0.3 m to 400 m: 52 steps)
MARCH_BISECTIONS = 20  # then narrowed to a millionth of the last step
SLOPE_STEP_M = 0.25  # the ground's slope under a pixel, by forward differences over this (under the camera: 1 m)
SUN_DIRECTION = np.array([0.45, -0.8, 0.4]) / np.linalg.norm([0.45, -0.8, 0.4])  # towards the sun, y down
TILE_PX = 8  # block side (pixels) for finding a quad's pixels through a lens: small blocks test few extra pixels
MATERIALS = ("sky", "asphalt", "grass", "facade", "brick", "foliage", "bark", "hills")
ROLLING_BAND_ROWS = 4  # a rolling shutter's frame is rendered in bands of this many rows: at a readout of 30 ms over
# 188 rows each row is then seen at most 0.3 ms from its own time


@dataclass
class _Surface:
    """Per-pixel results of the geometry pass (flat arrays of H*W)."""

    depth: np.ndarray
    material: np.ndarray
    s_m: np.ndarray
    t_m: np.ndarray
    footprint_m: np.ndarray
    shade: np.ndarray


@dataclass(frozen=True)
class _Tiles:
    """Pixels in blocks of TILE_PX x TILE_PX: ``order`` (H*W,) lists the pixel indices block by block,
    block b holding ``order[start[b]:start[b + 1]]``, whose rays span ``lo`` .. ``hi`` (B, 2) in (xn, yn)."""

    order: np.ndarray
    start: np.ndarray
    lo: np.ndarray
    hi: np.ndarray


@dataclass(frozen=True)
class PixelRays:
    """The viewing ray of every pixel of an (H, W) image with intrinsics ``K``: normalised coordinates
    ``xn``, ``yn`` (each (H*W,)), so that the ray is (xn, yn, 1) in the camera frame (x right, y down).

    Through a lens (``tiles`` set) the rays are those of the undistorted pixel positions; ``tiles``
    then groups the pixels into blocks with the range of their rays, to find a quad's pixels."""

    K: np.ndarray
    size_hw: tuple[int, int]
    xn: np.ndarray
    yn: np.ndarray
    tiles: _Tiles | None = None


def pixel_rays(K: np.ndarray, size_hw: tuple[int, int], distortion: LensDistortion = NO_DISTORTION) -> PixelRays:
    """The rays of every pixel of an image through a pinhole camera ``K`` with lens ``distortion``."""
    h, w = size_hw
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    if distortion.is_none:
        return PixelRays(K, size_hw, ((u - K[0, 2]) / K[0, 0]).ravel(), ((v - K[1, 2]) / K[1, 1]).ravel())
    ideal = undistort_points(np.c_[u.ravel(), v.ravel()], K, distortion).astype(np.float64)
    xn, yn = (ideal[:, 0] - K[0, 2]) / K[0, 0], (ideal[:, 1] - K[1, 2]) / K[1, 1]
    block = (v // TILE_PX * -(-w // TILE_PX) + u // TILE_PX).ravel().astype(np.int64)
    order = np.argsort(block, kind="stable")
    start = np.concatenate([[0], np.cumsum(np.bincount(block))])
    block_rays = np.c_[xn, yn][order]
    lo = np.minimum.reduceat(block_rays, start[:-1], axis=0)
    hi = np.maximum.reduceat(block_rays, start[:-1], axis=0)
    return PixelRays(K, size_hw, xn, yn, _Tiles(order, start, lo, hi))


@dataclass(frozen=True)
class RowBand:
    """Rows ``rows`` of an image, their ``rays`` (an image of their own: the principal point moved up by the band's
    top), and ``time_share``, when a rolling shutter exposes the band's middle row (a share of its readout time)."""

    rows: slice
    time_share: float
    rays: PixelRays


def row_bands(K: np.ndarray, size_hw: tuple[int, int], distortion: LensDistortion = NO_DISTORTION,
              band_rows: int = ROLLING_BAND_ROWS) -> list[RowBand]:
    """An (H, W) image through ``K`` and ``distortion`` as bands of ``band_rows`` rows, top to bottom; row ``y`` is
    exposed ``y / H`` of the readout after the first."""
    h, w = size_hw
    edges = [*range(0, h, band_rows), h]
    bands = []
    for top, bottom in zip(edges[:-1], edges[1:], strict=True):
        shifted = K.copy()
        shifted[1, 2] -= top
        bands.append(RowBand(slice(top, bottom), (top + bottom - 1) / 2.0 / h,
                             pixel_rays(shifted, (bottom - top, w), distortion)))
    return bands


def render_rolling_shutter(world: World, textures: dict[str, Texture], T_world_cam_bands: np.ndarray,
                           bands: list[RowBand]) -> tuple[np.ndarray, np.ndarray]:
    """Grey image (H, W) uint8 and depth (H, W) float32 of one view whose row ``bands`` are each seen from their own
    pose (``T_world_cam_bands`` (B, 4, 4), camera to world, at each band's ``time_share`` of the readout)."""
    h, w = bands[-1].rows.stop, bands[0].rays.size_hw[1]
    image, depth = np.empty((h, w), np.uint8), np.empty((h, w), np.float32)
    for band, T_world_cam in zip(bands, T_world_cam_bands, strict=True):
        image[band.rows], depth[band.rows] = render(world, textures, T_world_cam, band.rays)
    return image, depth


def render(world: World, textures: dict[str, Texture], T_world_cam: np.ndarray, rays: PixelRays
           ) -> tuple[np.ndarray, np.ndarray]:
    """Grey image (H, W) uint8 and depth (H, W) float32 (camera z, metres, inf = sky) of one view."""
    R, origin = T_world_cam[:3, :3], T_world_cam[:3, 3]
    directions = R @ np.stack([rays.xn, rays.yn, np.ones_like(rays.xn)])  # world ray per unit camera depth, (3, P)
    surface = _terrain(world, origin, directions, rays.K[0, 0])
    for face in _visible_faces(world, T_world_cam):
        _rasterise_quad(surface, face, R, origin, rays)
    intensity = _shade(world, textures, surface, origin, directions)
    image = np.clip(intensity * 255.0 + 0.5, 0, 255).astype(np.uint8).reshape(rays.size_hw)
    return image, surface.depth.reshape(rays.size_hw).astype(np.float32)


def _terrain(world: World, origin: np.ndarray, d: np.ndarray, focal_px: float) -> _Surface:
    n = d.shape[1]
    hit, t = _ground_hits(world, origin, d.astype(np.float32))
    dc = d[:, hit].astype(np.float32)
    x = origin[0] + t * dc[0]
    z = origin[2] + t * dc[2]
    lateral = world.lookup(world.lateral_m, x, z)
    along = world.lookup(world.along_m, x, z)
    scene = world.lookup(world.scene_index, x, z, nearest=True).astype(int)
    half_road = np.asarray([ROAD_HALF_WIDTH_M[k] for k in SCENE_TYPES], np.float32)[scene]
    on_road = np.abs(lateral) < half_road
    ray_norm = np.linalg.norm(dc, axis=0)
    # the cosine between the ray and the ground's normal (the ground's slope by forward differences: on a climb the
    # road ahead faces the camera more than level ground would)
    _, slope_x, slope_z = _ground_and_slope(world, x, z, SLOPE_STEP_M)
    grazing = (dc[1] - slope_x * dc[0] - slope_z * dc[2]) / (ray_norm * np.sqrt(1 + slope_x**2 + slope_z**2))
    shade = np.asarray([SCENE_BRIGHTNESS[k] for k in SCENE_TYPES], np.float32)[scene]
    shade = np.where(on_road & _lane_marking(lateral, along, half_road), shade * 2.3, shade)
    surface = _Surface(
        depth=np.full(n, np.inf),
        material=np.zeros(n, np.int8),
        s_m=np.zeros(n, np.float32),
        t_m=np.zeros(n, np.float32),
        footprint_m=np.ones(n, np.float32),
        shade=np.ones(n, np.float32),
    )
    surface.depth[hit] = t
    surface.material[hit] = np.where(on_road, MATERIALS.index("asphalt"), MATERIALS.index("grass"))
    # road coordinates follow the road (along, lateral); grass uses world x, z
    surface.s_m[hit] = np.where(on_road, along, x)
    surface.t_m[hit] = np.where(on_road, lateral, z)
    surface.footprint_m[hit] = t * ray_norm / focal_px / np.sqrt(np.maximum(grazing, 0.02))
    surface.shade[hit] = shade
    return surface


def _ground_and_slope(world: World, x: np.ndarray, z: np.ndarray, step_m: float
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ground's height (y, down) at world points ``x, z`` and its slopes along x and z (forward differences
    over ``step_m`` metres)."""
    ground = world.lookup(world.ground_y, x, z)
    return (ground, (world.lookup(world.ground_y, x + step_m, z) - ground) / step_m,
            (world.lookup(world.ground_y, x, z + step_m) - ground) / step_m)


def _ground_hits(world: World, origin: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where rays ``d`` (3, N) (world frame, per unit camera depth) from ``origin`` first reach the ground within
    ``MAX_DEPTH_M``: the indices (K,) of the rays that do and their depths (K,) float32.

    Rays that fall towards the ground's plane under the camera start where they meet that plane; Newton steps with
    the plane's slope for the ground's, then secant steps, are accepted where the ray ends within
    ``HIT_TOLERANCE_M`` (+ a share of the depth) of the ground. The rest (rays the steps do not bring to the ground,
    the sky) are marched (:func:`_march_to_ground`). Starting from level ground instead missed the road ahead on a
    climb: the iteration diverges where the ground along a ray rises faster than the ray falls."""
    n = d.shape[1]
    (ground_here,), (slope_x,), (slope_z,) = _ground_and_slope(world, origin[:1], origin[2:3], 1.0)
    fall = d[1] - slope_x * d[0] - slope_z * d[2]  # towards the plane, per unit depth
    candidates = np.flatnonzero(fall > 1e-4)
    dc, fall = d[:, candidates], fall[candidates]

    def height_above_ground(t: np.ndarray) -> np.ndarray:  # y down: negative once the ray is below the ground
        return world.lookup(world.ground_y, origin[0] + t * dc[0], origin[2] + t * dc[2]) - origin[1] - t * dc[1]

    t = ((ground_here - origin[1]) / fall).astype(np.float32)
    for _ in range(TERRAIN_ITERATIONS):
        previous_t = np.minimum(t, MAX_DEPTH_M)
        t = (previous_t + height_above_ground(previous_t) / fall).astype(np.float32)
    previous_h = height_above_ground(previous_t)
    for _ in range(SECANT_STEPS):
        t = np.clip(t, NEAR_M, MAX_DEPTH_M)
        h = height_above_ground(t)
        slope = (h - previous_h) / np.where(t != previous_t, t - previous_t, np.float32(1))
        step = np.where(np.abs(slope) > 1e-6, h / np.where(np.abs(slope) > 1e-6, slope, 1), 0)
        previous_t, previous_h, t = t, h, (t - np.clip(step, -0.5 * t, 0.5 * t)).astype(np.float32)
    ok = (t > NEAR_M) & (t < MAX_DEPTH_M) & (np.abs(height_above_ground(t)) < HIT_TOLERANCE_M + 1e-5 * t)
    missed = np.setdiff1d(np.arange(n), candidates[ok], assume_unique=True)
    marched, t_marched = _march_to_ground(world, origin, d[:, missed])
    hit = np.concatenate([candidates[ok], missed[marched]])
    order = np.argsort(hit)
    return hit[order], np.concatenate([t[ok], t_marched])[order]


def _march_to_ground(world: World, origin: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where rays ``d`` (3, M) (world frame, per unit camera depth) from ``origin`` first reach the ground: the
    indices (K,) of those that do within ``MAX_DEPTH_M`` and their depths (K,) float32. Each ray starts where it
    last ran above the highest ground within its horizontal distance (radii doubling from ``NEAR_M``); steps that
    grow by ``MARCH_GROWTH`` find the first point below the ground, and bisection narrows it to
    ``MARCH_BISECTIONS`` halvings. A ray that has risen above the highest ground within ``MAX_DEPTH_M`` is not
    followed further (the sky)."""
    dx, dy, dz = (np.ascontiguousarray(row, dtype=np.float32) for row in d)
    horizontal = np.maximum(np.hypot(dx, dz), 1e-6)
    # how high the ground rises above the camera within each radius: a ray cannot meet the ground while it runs
    # above the highest ground within its horizontal distance, so its march starts at the last radius where it does
    radii = NEAR_M * 2.0 ** np.arange(int(np.ceil(np.log2(MAX_DEPTH_M / NEAR_M))) + 1)
    rows, cols = world.ground_y.shape
    highest = []
    for radius in radii:
        (col_lo,), (row_lo,) = world.grid_coords(origin[:1] - radius, origin[2:3] - radius)
        (col_hi,), (row_hi,) = world.grid_coords(origin[:1] + radius, origin[2:3] + radius)
        around = world.ground_y[max(0, int(row_lo)):min(rows, int(row_hi) + 2),
                                max(0, int(col_lo)):min(cols, int(col_hi) + 2)]
        highest.append(origin[1] - float(around.min()) if around.size else -np.inf)  # metres above the camera
    lowest_on_ray = np.minimum(-dy[:, None] * (radii[None] / horizontal[:, None]), 0.0)  # within each radius
    clear = np.cumprod(np.asarray(highest)[None] < lowest_on_ray, axis=1).astype(bool)
    step_t = np.where(clear.any(axis=1), radii[np.maximum(clear.sum(axis=1) - 1, 0)] / horizontal,
                      NEAR_M).astype(np.float32)
    # nor can it meet the ground beyond a radius from which on it runs above the highest ground of every ring
    # further out (a rising ray: the sky)
    ring_clear = np.asarray(highest)[None, 1:] < -dy[:, None] * (radii[None, :-1] / horizontal[:, None])
    clear_onwards = np.cumprod(ring_clear[:, ::-1], axis=1)[:, ::-1].astype(bool)
    onwards_from = len(radii) - 1 - clear_onwards.sum(axis=1)  # the first ring clear from there on
    reach = np.minimum(radii[onwards_from] / horizontal, MAX_DEPTH_M).astype(np.float32)
    active = np.flatnonzero(~clear.all(axis=1) & (reach > step_t))
    below_at = np.full(len(dy), np.nan, np.float32)
    while len(active):
        t = np.minimum(step_t.take(active) * np.float32(MARCH_GROWTH), np.float32(MAX_DEPTH_M))
        step_t[active] = t
        ground = world.lookup(world.ground_y, origin[0] + t * dx.take(active), origin[2] + t * dz.take(active))
        below = origin[1] + t * dy.take(active) >= ground
        below_at[active[below]] = t[below]
        active = active[~below & (t < reach.take(active))]
    found = np.flatnonzero(np.isfinite(below_at))
    fx, fy, fz = dx[found], dy[found], dz[found]
    high = below_at[found]
    low = high / np.float32(MARCH_GROWTH)
    for _ in range(MARCH_BISECTIONS):
        middle = (low + high) / 2
        ground = world.lookup(world.ground_y, origin[0] + middle * fx, origin[2] + middle * fz)
        below = origin[1] + middle * fy >= ground
        high = np.where(below, middle, high)
        low = np.where(below, low, middle)
    return found, ((low + high) / 2).astype(np.float32)


def _lane_marking(lateral: np.ndarray, along: np.ndarray, half_road: np.ndarray) -> np.ndarray:
    """White lines: dashed centre line (3 m of every 9 m) 1.8 m left of the path, solid edge lines."""
    centre = (np.abs(lateral + 1.8) < 0.08) & (np.mod(along, 9.0) < 3.0)
    edge = np.abs(np.abs(lateral) - (half_road - 0.3)) < 0.1
    return centre | edge


def _visible_faces(world: World, T_world_cam: np.ndarray):
    """Quads (corner, edge_a, edge_b, normal, material, offset, brightness) of boxes near the camera."""
    boxes = world.boxes
    if len(boxes) == 0:
        return
    origin = T_world_cam[:3, 3]
    forward = T_world_cam[:3, 2]
    rel = boxes.centre_xz - origin[[0, 2]]
    distance = np.hypot(rel[:, 0], rel[:, 1])
    extent = np.hypot(boxes.half_along, boxes.half_across)
    ahead = rel @ forward[[0, 2]] > -extent - 1.0
    for i in np.flatnonzero((distance < OBJECT_RANGE_M + extent) & ahead):
        f = np.array([np.sin(boxes.yaw[i]), 0.0, np.cos(boxes.yaw[i])])
        r = np.array([f[2], 0.0, -f[0]])
        up = np.array([0.0, -1.0, 0.0])
        base = np.array([boxes.centre_xz[i, 0], boxes.base_y[i], boxes.centre_xz[i, 1]])
        a, c, h = boxes.half_along[i], boxes.half_across[i], boxes.height[i]
        material = MATERIALS.index(boxes.texture[i])
        offset, bright = boxes.texture_offset[i], boxes.brightness[i]
        sides = [(f, r, a, c), (-f, -r, a, c), (r, -f, c, a), (-r, f, c, a)]
        for normal, tangent, half_normal, half_tangent in sides:
            corner = base + normal * half_normal - tangent * half_tangent
            if normal @ (origin - corner) > 0:
                yield corner, tangent * 2 * half_tangent, up * h, normal, material, offset, bright
        top_corner = base + up * h - f * a - r * c
        if up @ (origin - top_corner) > 0:
            yield top_corner, f * 2 * a, r * 2 * c, up, material, offset, bright


def _clip_near(points_cam: np.ndarray) -> np.ndarray | None:
    """The part (M', 3) of a convex polygon (M, 3) in front of the near plane, or None."""
    clipped = []
    for i in range(len(points_cam)):
        p, q = points_cam[i], points_cam[(i + 1) % len(points_cam)]
        if p[2] >= NEAR_M:
            clipped.append(p)
        if (p[2] >= NEAR_M) != (q[2] >= NEAR_M):
            clipped.append(p + (q - p) * (NEAR_M - p[2]) / (q[2] - p[2]))
    return np.array(clipped) if clipped else None


def _polygon_pixels(points_cam: np.ndarray, rays: PixelRays) -> np.ndarray | None:
    """Indices of the pixels that may see a convex polygon (M, 3) in camera coordinates: its projected
    bounding box (pinhole), or the blocks whose rays overlap the box of its rays (through a lens)."""
    pts = _clip_near(points_cam)
    if pts is None:
        return None
    if rays.tiles is not None:
        x, y, tiles = pts[:, 0] / pts[:, 2], pts[:, 1] / pts[:, 2], rays.tiles
        hit = np.flatnonzero((tiles.lo[:, 0] <= x.max()) & (tiles.hi[:, 0] >= x.min())
                             & (tiles.lo[:, 1] <= y.max()) & (tiles.hi[:, 1] >= y.min()))
        if not len(hit):
            return None
        return np.concatenate([tiles.order[tiles.start[b]:tiles.start[b + 1]] for b in hit])
    K = rays.K
    u = K[0, 0] * pts[:, 0] / pts[:, 2] + K[0, 2]
    v = K[1, 1] * pts[:, 1] / pts[:, 2] + K[1, 2]
    h, w = rays.size_hw
    u0, u1 = max(int(np.floor(u.min())), 0), min(int(np.ceil(u.max())) + 1, w)
    v0, v1 = max(int(np.floor(v.min())), 0), min(int(np.ceil(v.max())) + 1, h)
    if u0 >= u1 or v0 >= v1:
        return None
    return (np.arange(v0, v1)[:, None] * w + np.arange(u0, u1)[None, :]).ravel()


def _rasterise_quad(surface: _Surface, face, R, origin, rays: PixelRays) -> None:
    corner, edge_a, edge_b, normal, material, offset, bright = face
    corners_world = np.stack([corner, corner + edge_a, corner + edge_a + edge_b, corner + edge_b])
    corners_cam = (corners_world - origin) @ R
    index = _polygon_pixels(corners_cam, rays)
    if index is None:
        return
    K = rays.K
    x, y = rays.xn[index], rays.yn[index]
    n_cam = R.T @ normal
    p_cam = R.T @ (corner - origin)
    denominator = n_cam[0] * x + n_cam[1] * y + n_cam[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        z = (n_cam @ p_cam) / denominator
    a_cam, b_cam = R.T @ edge_a, R.T @ edge_b
    la, lb = np.linalg.norm(edge_a), np.linalg.norm(edge_b)
    rel_x, rel_y, rel_z = z * x - p_cam[0], z * y - p_cam[1], z - p_cam[2]
    s = (a_cam[0] * rel_x + a_cam[1] * rel_y + a_cam[2] * rel_z) / la
    t = (b_cam[0] * rel_x + b_cam[1] * rel_y + b_cam[2] * rel_z) / lb
    inside = (z > NEAR_M) & (s >= 0) & (s <= la) & (t >= 0) & (t <= lb) & (z < surface.depth[index])
    if not inside.any():
        return
    index, z, s, t = index[inside], z[inside], s[inside], t[inside]
    ray_norm = np.sqrt(x[inside] ** 2 + y[inside] ** 2 + 1.0)
    cos_incidence = np.abs(denominator[inside]) / ray_norm
    surface.depth[index] = z
    surface.material[index] = material
    surface.s_m[index] = s + offset
    surface.t_m[index] = t
    surface.footprint_m[index] = z * ray_norm / K[0, 0] / np.sqrt(np.maximum(cos_incidence, 0.02))
    surface.shade[index] = bright * (0.6 + 0.4 * max(float(normal @ SUN_DIRECTION), 0.0))


def _shade(world: World, textures: dict[str, Texture], surface: _Surface, origin, d) -> np.ndarray:
    intensity = np.zeros(surface.depth.shape, np.float32)
    for material_index, name in enumerate(MATERIALS):
        pixels = np.flatnonzero(surface.material == material_index)
        if len(pixels) == 0:
            continue
        if name == "sky":
            intensity[pixels] = _backdrop(world, textures, d[:, pixels])
            continue
        sampled = textures[name].sample(surface.s_m[pixels], surface.t_m[pixels], surface.footprint_m[pixels])
        intensity[pixels] = sampled * surface.shade[pixels]
    return np.clip(intensity, 0.0, 1.0)


def _backdrop(world: World, textures: dict[str, Texture], d: np.ndarray) -> np.ndarray:
    """Scenery at infinity: a hill silhouette and cloudy sky, a function of ray direction only."""
    azimuth = np.arctan2(d[0], d[2])
    elevation = np.arctan2(-d[1], np.hypot(d[0], d[2]))
    phases = np.random.default_rng(world.seed + 11).uniform(0, 2 * np.pi, 4)
    ridge = 0.035 + 0.02 * np.sin(3 * azimuth + phases[0]) + 0.012 * np.sin(7 * azimuth + phases[1]) \
        + 0.006 * np.sin(17 * azimuth + phases[2])
    footprint = np.full(azimuth.shape, 1.0 / 718.0, np.float32)
    out = np.empty(azimuth.shape, np.float32)
    hill = elevation < ridge
    sky = ~hill
    out[hill] = textures["hills"].sample(azimuth[hill] * 4.0, elevation[hill] * 4.0, footprint[hill] * 4.0)
    brightening = 0.95 + 0.5 * np.clip(elevation[sky], 0, 0.3)
    out[sky] = textures["sky"].sample(azimuth[sky] * 3.0, elevation[sky] * 3.0, footprint[sky] * 3.0) * brightening
    return out
