"""A real drive's poses made into a path a synthetic world can be built along: turned level, with heights a car
can drive, one height wherever the drive passes the same place again.

Poses are KITTI camera-to-world (x right, y down, z forward), metres.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix, vstack
from scipy.sparse.linalg import spsolve
from scipy.spatial import cKDTree

from flowvo.geometry import skew


def levelled(T_world_cam: np.ndarray, prior_weight: float = 1e-3) -> np.ndarray:
    """Camera-to-world poses (N, 4, 4) of a replayed drive turned about the world's origin into a level
    world frame, for building and rendering its world (whose road is built level across, y down).

    A real drive's poses are given in its first camera's frame, tilted against gravity by the grade and
    roll where it started (KITTI 08: 4 degrees). "Down" is estimated as the direction the cameras' x axes
    are most nearly perpendicular to (a car's lateral axis stays about level as it turns): the eigenvector
    of the smallest eigenvalue of sum(x x^T), plus ``prior_weight`` times the number of poses times the
    projector away from the given y axis, so that a drive that never turns keeps the given frame in the
    direction its x axes cannot tell. Relative motions are unchanged."""
    lateral = T_world_cam[:, :3, 0]
    y_axis = np.array([0.0, 1.0, 0.0])
    scatter = lateral.T @ lateral + prior_weight * len(lateral) * (np.eye(3) - np.outer(y_axis, y_axis))
    down = np.linalg.eigh(scatter)[1][:, 0]
    down *= np.sign(down[1])
    axis = np.cross(down, y_axis)  # the rotation taking ``down`` onto the y axis (Rodrigues)
    sine, cosine = float(np.linalg.norm(axis)), float(down @ y_axis)
    if sine < 1e-12:
        return T_world_cam.copy()
    axis /= sine
    cross = skew(axis)  # Rodrigues written out, not so3_exp(axis * angle): that differs in the last bits, and the
    # spec digests that decide whether rendered frames on disk are reused hash these poses exactly
    rotation = np.eye(3) + sine * cross + (1.0 - cosine) * cross @ cross
    level = np.eye(4)
    level[:3, :3] = rotation
    return level @ T_world_cam


MAX_CLIMB_OFF_AXIS_DEG = 5.0  # KITTI 00-10 outside 08's glitch: a moving step climbs within 3.2 deg of its camera's
# forward axis beyond the drive's median (99th percentile); 08's first 100 frames climb 16 m at 10-62 deg while the
# camera looks level (the GPS/INS height, not the road)
MOVING_STEP_M = 0.1  # steps at least this long horizontally measure the drive's median offset (a standstill's height
# jitter says nothing of it)


def drivable_heights(T_world_cam: np.ndarray, max_off_axis_deg: float = MAX_CLIMB_OFF_AXIS_DEG) -> np.ndarray:
    """Camera-to-world poses (N, 4, 4) of a level replayed drive (y down) whose height changes a car could drive:
    each step climbs or falls at most ``max_off_axis_deg`` steeper than its camera's forward axis (the mean of the
    step's two cameras), after the drive's median offset between the two (the camera's mounting); a step beyond
    that takes the camera's slope (at that offset) instead, and the positions after it follow. A replay's world is
    built along its path: a ground-truth height that jumps while the camera looks level (KITTI 08's start) would
    build a ramp no car drives. Horizontal positions and rotations are unchanged."""
    horizontal = _horizontal_steps(T_world_cam[:, :3, 3])
    climb = -np.diff(T_world_cam[:, 1, 3])  # y is down
    forward = T_world_cam[:-1, :3, 2] + T_world_cam[1:, :3, 2]
    axis_elevation = np.arctan2(-forward[:, 1], np.hypot(forward[:, 0], forward[:, 2]))
    moving = horizontal >= MOVING_STEP_M
    offset = float(np.median(np.arctan2(climb, horizontal)[moving] - axis_elevation[moving])) if moving.any() else 0.0
    expected = axis_elevation + offset
    limit = np.radians(max_off_axis_deg)
    plausible = (climb >= horizontal * np.tan(expected - limit)) & (climb <= horizontal * np.tan(expected + limit))
    allowed = np.where(plausible, climb, horizontal * np.tan(expected))
    drivable = T_world_cam.copy()
    drivable[1:, 1, 3] = T_world_cam[0, 1, 3] - np.cumsum(allowed)
    return drivable


REVISIT_RADIUS_M = 8.0  # two passes closer than this horizontally share the ground between them: one height
REVISIT_APART_M = 50.0  # ... when more driving than this lies between them (nearer, the path's grade separates them)
REVISIT_SIGMA_M = 0.02  # how closely two passes' heights are made to agree
NODE_SPACING_M = 2.0  # the height correction is linear in the distance driven between nodes this far apart
GRADE_SIGMA = 0.003  # how much it may change the drive's grade (m/m) ...
BEND_SIGMA_M = 1e-4  # ... and how sharply (the second difference of three nodes)
# with these, KITTI 00-09's passes agree within 0.52 m (they differed by up to 4.9 m) for grades changed by at most
# 1.4 % (02), 1.3 % (08), 0.6 % (09)


def consistent_heights(T_world_cam: np.ndarray) -> np.ndarray:
    """Camera-to-world poses (N, 4, 4) of a level replayed drive (y down) whose heights agree where it passes the
    same place again: a smooth height correction, a function of the distance driven (so a standstill stays
    still), fitted by least squares to make every pose agree with the nearest pose of another pass within
    ``REVISIT_RADIUS_M`` while changing the drive's grade as little and as smoothly as possible; none at the first
    pose. A world is one heightfield built along its path: ground truth whose height drifts between two passes
    (KITTI 08 comes back past its start 4.8 m higher, 09 to its start 3.9 m) built a cliff between them.
    Horizontal positions and rotations are unchanged; a drive that never comes back is returned as it is."""
    positions = T_world_cam[:, :3, 3]
    driven = np.concatenate([[0.0], np.cumsum(_horizontal_steps(positions))])
    pairs = _revisits(positions[:, [0, 2]], driven)
    if not len(pairs):
        return T_world_cam.copy()
    nodes = int(np.ceil(driven[-1] / NODE_SPACING_M)) + 2
    left = np.minimum((driven // NODE_SPACING_M).astype(np.int64), nodes - 2)  # each pose between two nodes
    share = driven / NODE_SPACING_M - left
    first, second = pairs[:, 0], pairs[:, 1]
    pair_nodes = np.stack([left[first], left[first] + 1, left[second], left[second] + 1], 1)
    pair_weights = np.stack([1 - share[first], share[first], share[second] - 1, -share[second]], 1)
    agree = coo_matrix((pair_weights.ravel() / REVISIT_SIGMA_M, (np.repeat(np.arange(len(pairs)), 4),
                                                                 pair_nodes.ravel())), shape=(len(pairs), nodes))
    bend = _stencil([1.0, -2.0, 1.0], nodes, BEND_SIGMA_M)
    grade = _stencil([-1.0, 1.0], nodes, NODE_SPACING_M * GRADE_SIGMA)
    start = coo_matrix(([1.0 / REVISIT_SIGMA_M], ([0], [0])), shape=(1, nodes))
    A = vstack([agree, bend, grade, start]).tocsr()
    b = np.zeros(A.shape[0])
    b[: len(pairs)] = (positions[second, 1] - positions[first, 1]) / REVISIT_SIGMA_M
    correction = spsolve((A.T @ A).tocsc(), A.T @ b)
    correction -= correction[0]  # the start row only fixes the offset the other rows leave free
    consistent = T_world_cam.copy()
    consistent[:, 1, 3] += (1 - share) * correction[left] + share * correction[left + 1]
    return consistent


def _horizontal_steps(positions: np.ndarray) -> np.ndarray:
    """The horizontal length (metres, over x and z) of each step between positions (N, 3): (N - 1,)."""
    steps = np.diff(positions, axis=0)
    return np.hypot(steps[:, 0], steps[:, 2])


def _stencil(coefficients: list[float], nodes: int, sigma: float) -> coo_matrix:
    """One row per run of ``len(coefficients)`` consecutive nodes, applying ``coefficients / sigma`` to it."""
    width = len(coefficients)
    runs = np.arange(nodes - width + 1)
    return coo_matrix((np.tile(coefficients, len(runs)) / sigma,
                       (np.repeat(runs, width), (runs[:, None] + np.arange(width)).ravel())),
                      shape=(len(runs), nodes))


def _revisits(horizontal_xz: np.ndarray, driven_m: np.ndarray) -> np.ndarray:
    """Pairs (P, 2) of poses on two passes of the same place: each pose with the nearest pose within
    ``REVISIT_RADIUS_M`` that lies more than ``REVISIT_APART_M`` of driving away (the nearest only: the others
    lie further along that pass, up or down its grade)."""
    neighbours = cKDTree(horizontal_xz).query_ball_point(horizontal_xz, REVISIT_RADIUS_M, return_sorted=False)
    pairs = []
    for pose, near in enumerate(neighbours):
        near = np.asarray(near, dtype=np.int64)
        near = near[np.abs(driven_m[near] - driven_m[pose]) > REVISIT_APART_M]
        if len(near):
            pairs.append((pose, near[np.argmin(np.hypot(*(horizontal_xz[near] - horizontal_xz[pose]).T))]))
    return np.array(pairs, dtype=np.int64).reshape(-1, 2)
