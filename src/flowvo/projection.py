"""Pinhole projection maths (optionally behind a lens): the motion field (true optical flow) from depth and pose.

Flow convention (one source of truth): ``flow_px (H, W, 2)``, u right and v down, in pixels of the frame
it was computed on; forward flow maps pixel p of frame t to p + flow(p) in frame t+1.
"""

from __future__ import annotations

import numpy as np

from flowvo.camera import NO_DISTORTION, LensDistortion, distort_points, undistort_points


def flow_from_depth(depth_m: np.ndarray, K: np.ndarray, T_next_cur: np.ndarray,
                    distortion: LensDistortion = NO_DISTORTION) -> tuple[np.ndarray, np.ndarray]:
    """Forward flow (H, W, 2) float32 and the depth of each point in the next camera (H, W).

    ``depth_m`` is camera z of frame t (inf for points at infinity, which move by rotation only);
    ``T_next_cur`` maps frame-t camera coordinates to frame-t+1 camera coordinates
    (``inv(T_world_next) @ T_world_cur``). With a lens ``distortion`` both frames are the distorted
    images (pixel rays undistorted, landing points distorted again).
    """
    h, w = depth_m.shape
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    ideal_u, ideal_v = u, v
    if not distortion.is_none:
        ideal = undistort_points(np.c_[u.ravel(), v.ravel()], K, distortion).astype(np.float64)
        ideal_u, ideal_v = ideal[:, 0].reshape(h, w), ideal[:, 1].reshape(h, w)
    x = (ideal_u - K[0, 2]) / K[0, 0]
    y = (ideal_v - K[1, 2]) / K[1, 1]
    inverse_depth = np.where(np.isfinite(depth_m), 1.0 / np.maximum(depth_m, 1e-6), 0.0)
    # homogeneous point (x, y, 1, 1/z) scaled by z: works for points at infinity too
    R, t = T_next_cur[:3, :3], T_next_cur[:3, 3]
    X = R[0, 0] * x + R[0, 1] * y + R[0, 2] + t[0] * inverse_depth
    Y = R[1, 0] * x + R[1, 1] * y + R[1, 2] + t[1] * inverse_depth
    Z = R[2, 0] * x + R[2, 1] * y + R[2, 2] + t[2] * inverse_depth
    with np.errstate(divide="ignore", invalid="ignore"):
        u_next = K[0, 0] * X / Z + K[0, 2]
        v_next = K[1, 1] * Y / Z + K[1, 2]
        next_depth = np.where(inverse_depth > 0, Z / inverse_depth, np.inf)
    if not distortion.is_none:
        ahead = np.isfinite(u_next) & np.isfinite(v_next) & (Z > 0)
        landing = distort_points(np.c_[u_next[ahead], v_next[ahead]], K, distortion)
        u_next[ahead], v_next[ahead] = landing[:, 0], landing[:, 1]
    flow = np.stack([u_next - u, v_next - v], axis=-1).astype(np.float32)
    return flow, next_depth


def occlusion_mask(flow_px: np.ndarray, next_depth_m: np.ndarray, depth_next_frame_m: np.ndarray,
                   relative_tolerance: float = 0.03) -> np.ndarray:
    """True where the point of frame t is not visible in frame t+1: it leaves the image, goes behind the
    camera, or lands behind another surface (its depth exceeds the rendered depth there)."""
    h, w = next_depth_m.shape
    v, u = np.mgrid[0:h, 0:w]
    target_u = np.rint(u + flow_px[..., 0])
    target_v = np.rint(v + flow_px[..., 1])
    inside = (target_u >= 0) & (target_u < w) & (target_v >= 0) & (target_v < h) & (next_depth_m > 0)
    tu = np.clip(np.nan_to_num(target_u), 0, w - 1).astype(int)
    tv = np.clip(np.nan_to_num(target_v), 0, h - 1).astype(int)
    seen = depth_next_frame_m[tv, tu]
    both_far = ~np.isfinite(next_depth_m) & ~np.isfinite(seen)
    with np.errstate(invalid="ignore"):
        visible = both_far | (next_depth_m <= seen * (1 + relative_tolerance) + 0.05)
    return ~(inside & visible)
