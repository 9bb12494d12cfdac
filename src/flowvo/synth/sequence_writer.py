"""Write synthetic sequences in the KITTI odometry layout (frames, calib, times, poses, optional GT flow).

Every file is written atomically; frames already on disk are kept, so an interrupted run resumes.
"""

from __future__ import annotations

import hashlib
import multiprocessing
import os
import signal
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from flowvo.camera import LensDistortion
from flowvo.geometry import invert_se3
from flowvo.io.atomic import atomic_path, write_json_atomic, write_text_atomic
from flowvo.kitti.calib import Calibration, format_calibration
from flowvo.kitti.poses import write_kitti_poses
from flowvo.progress import progress
from flowvo.projection import flow_from_depth, occlusion_mask
from flowvo.synth.bonnet import Bonnet, make_bonnet
from flowvo.synth.frame_rate import frames_spanning, poses_at, resample_poses
from flowvo.synth.render import PixelRays, RowBand, pixel_rays, render, render_rolling_shutter, row_bands
from flowvo.synth.synth_camera import PATH_RATE_HZ, SynthCamera
from flowvo.synth.textures import make_textures
from flowvo.synth.world import World, build_world
from flowvo.trajectory import Trajectory

KITTI_SIZE_HW = (376, 1241)
KITTI_FOCAL_PX = 718.856
KITTI_PRINCIPAL_PX = (607.1928, 185.2157)
STEREO_BASELINE_M = 0.54


@dataclass(frozen=True)
class SynthSpec:
    """What to render for one sequence: the drive (``T_world_cam``, camera-to-world poses at the path's
    10 Hz, in the frame the world is built in: y down along gravity for a generated drive; the world
    follows it), the world seed and scene, the image scale, the camera, and how many
    ``frames`` to render at the camera's frame rate (None: the whole drive), and how many times finer than by default
    the ground's texture is (:func:`flowvo.synth.textures.make_textures`)."""

    T_world_cam: np.ndarray
    seed: int
    scale: float = 1.0
    scene: str | None = None
    gt_flow: bool = False
    camera: SynthCamera = field(default_factory=SynthCamera)
    frames: int | None = None
    ground_texture_scale: float = 1.0

    @property
    def frame_count(self) -> int:
        """How many frames are rendered, at the camera's frame rate."""
        return self.frames or frames_spanning(len(self.T_world_cam), PATH_RATE_HZ, self.camera.fps)

    def frame_poses(self) -> np.ndarray:
        """Camera-to-world poses (F, 4, 4) of the rendered frames, at the camera's frame rate; the drive's
        poses are a level camera's, the rendered camera is pitched and rolled on it by its mounting."""
        return self._mounted(resample_poses(self.T_world_cam, PATH_RATE_HZ, self.camera.fps, self.frame_count))

    def band_poses(self, time_shares: np.ndarray) -> np.ndarray:
        """Camera-to-world poses (F, B, 4, 4) of a rolling shutter's row bands: frame ``i``'s band ``b`` at
        ``i / fps + time_shares[b] * readout`` (seconds; :func:`flowvo.synth.render.row_bands`), mounted as
        :meth:`frame_poses`."""
        frames = self.frame_count
        times_s = np.arange(frames)[:, None] / self.camera.fps + np.asarray(time_shares)[None] * \
            self.camera.readout_ms / 1000.0
        level = poses_at(self.T_world_cam, PATH_RATE_HZ, times_s.ravel()).reshape(frames, len(time_shares), 4, 4)
        return self._mounted(level)

    def _mounted(self, level: np.ndarray) -> np.ndarray:
        """Level camera poses (..., 4, 4) with the camera pitched and rolled on them by its mounting."""
        return level if not (self.camera.pitch_deg or self.camera.roll_deg) else level @ self.camera.mounting()


RENDERER_GENERATION = 2  # raised when the same spec renders other frames (2: the road ahead on climbs), so that
# frames of an earlier renderer are never resumed beside new ones


def spec_digest(spec: SynthSpec) -> str:
    """SHA-256 of everything that determines the rendered files (renderer generation, poses, seed, scale, scene,
    GT flow, camera): two runs with equal digests write identical sequences, so frames on disk may be reused
    (resume). KITTI's camera adds nothing, so renders made before the camera options resume."""
    digest = hashlib.sha256(np.ascontiguousarray(spec.T_world_cam, dtype=np.float64).tobytes())
    digest.update(f"renderer {RENDERER_GENERATION}".encode())
    digest.update(repr((spec.seed, float(spec.scale), spec.scene, spec.gt_flow)).encode())
    if not spec.camera.is_kitti:
        digest.update(repr((spec.camera, spec.frames)).encode())
    if spec.camera.bonnet_rows:
        digest.update(f"bonnet {spec.camera.bonnet_rows!r}".encode())
    if spec.camera.roll_deg:
        digest.update(f"roll {spec.camera.roll_deg!r}".encode())
    if spec.camera.readout_ms:
        digest.update(f"readout {spec.camera.readout_ms!r}".encode())
    if spec.ground_texture_scale != 1.0:
        digest.update(f"ground texture {spec.ground_texture_scale!r}".encode())
    return digest.hexdigest()


def intrinsics(scale: float, camera: SynthCamera | None = None) -> tuple[np.ndarray, tuple[int, int]]:
    """The intrinsics K (3, 3) and image size (H, W) of KITTI's image, scaled, with the focal length of
    ``camera``'s field of view (KITTI's without one)."""
    size = (int(round(KITTI_SIZE_HW[0] * scale)), int(round(KITTI_SIZE_HW[1] * scale)))
    K = np.array([[KITTI_FOCAL_PX, 0, KITTI_PRINCIPAL_PX[0]], [0, KITTI_FOCAL_PX, KITTI_PRINCIPAL_PX[1]], [0, 0, 1]])
    K[:2] *= scale
    if camera is not None and camera.fov_deg is not None:
        K[0, 0] = K[1, 1] = camera.focal_px(size[1], K[0, 0])
    return K, size


def kitti_calibration(K: np.ndarray, camera: SynthCamera | None = None) -> Calibration:
    """P0..P3 as in KITTI: P1 (right grey) at the 0.54 m baseline; colour cameras share the grey ones.
    A camera other than KITTI's adds its lens distortion, its height above the road, its mounting (pitch, roll) and
    its rolling shutter's readout time."""
    P0 = np.hstack([K, np.zeros((3, 1))])
    P1 = P0.copy()
    P1[0, 3] = -K[0, 0] * STEREO_BASELINE_M
    matrices = {"P0": P0, "P1": P1, "P2": P0.copy(), "P3": P1.copy()}
    if camera is None or camera.is_kitti:
        return Calibration(matrices)
    return Calibration(matrices, camera.distortion, camera.height_m, camera.pitch_deg or None, camera.roll_deg or None,
                       camera.readout_ms or None)


_worker_state: dict = {}


def _init_worker(world: World, seed: int, rays: PixelRays | list[RowBand], bonnet: Bonnet | None = None,
                 ground_texture_scale: float = 1.0) -> None:
    _worker_state.update(world=world, textures=make_textures(seed, ground_texture_scale), rays=rays, bonnet=bonnet)


def _render_one(pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One frame from ``pose`` (4, 4), or for a rolling shutter (the worker's rays in row bands) from each band's
    pose (B, 4, 4)."""
    state = _worker_state
    if isinstance(state["rays"], list):
        image, depth = render_rolling_shutter(state["world"], state["textures"], pose, state["rays"])
    else:
        image, depth = render(state["world"], state["textures"], pose, state["rays"])
    return (image, depth) if state["bonnet"] is None else state["bonnet"].paint(image, depth)


def _init_pool_worker(world: World, seed: int, rays: PixelRays | list[RowBand], bonnet: Bonnet | None = None,
                      ground_texture_scale: float = 1.0) -> None:
    """A render process: Ctrl-C is left to the parent, which stops the pool and reports one line."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _init_worker(world, seed, rays, bonnet, ground_texture_scale)


def write_sequence(root: str | Path, name: str, spec: SynthSpec, workers: int | None = None) -> Path:
    """Render one sequence into ``root`` and return its folder. Existing frames are reused: the caller
    (:func:`flowvo.synth.dataset.synthesize`) makes sure they belong to the same ``spec``."""
    root = Path(root)
    directory = root / "sequences" / name
    image_dir = directory / "image_0"
    image_dir.mkdir(parents=True, exist_ok=True)
    camera = spec.camera
    K, size = intrinsics(spec.scale, camera)
    poses = spec.frame_poses()
    write_text_atomic(directory / "calib.txt", format_calibration(kitti_calibration(K, camera)))
    write_text_atomic(directory / "times.txt", "".join(f"{i / camera.fps:.6e}\n" for i in range(len(poses))))
    relative_to_first = invert_se3(poses[0]) @ poses  # as KITTI's pose files are
    write_kitti_poses(root / "poses" / f"{name}.txt", Trajectory.from_poses(relative_to_first))
    write_json_atomic(directory / "synthetic.json", {
        "synthetic": True, "seed": spec.seed, "scene": spec.scene or "varied", "scale": spec.scale,
        "frames": len(poses), "generator": "flowvo synth", "spec_sha256": spec_digest(spec),
        "camera": camera.record(),
        **({} if spec.ground_texture_scale == 1.0 else {"ground_texture_scale": spec.ground_texture_scale}),
    })
    world = build_world(spec.T_world_cam, spec.seed, spec.scene, camera.height_m)
    rays: PixelRays | list[RowBand] = row_bands(K, size, camera.distortion) if camera.readout_ms else \
        pixel_rays(K, size, camera.distortion)
    render_poses = poses if isinstance(rays, PixelRays) else \
        spec.band_poses(np.array([band.time_share for band in rays]))  # each frame's, or each of its row bands'
    bonnet = make_bonnet(size, camera.bonnet_rows, K, spec.seed) if camera.bonnet_rows else None
    todo = [i for i in range(len(poses)) if not (image_dir / f"{i:06d}.png").exists()]
    if spec.gt_flow:
        todo = list(range(len(poses)))  # depth of every frame is needed for the flow
    workers = workers or max(1, min(os.cpu_count() or 1, 8))
    frames = [render_poses[i] for i in todo]
    with ExitStack() as stack:
        if workers > 1 and len(frames) > 4:
            # spawn, not fork: a forked child inherits OpenCV's thread pool in a locked state and hangs
            context = multiprocessing.get_context("spawn")
            pool = stack.enter_context(context.Pool(workers, _init_pool_worker,
                                                        (world, spec.seed, rays, bonnet, spec.ground_texture_scale)))
            results = pool.imap(_render_one, frames, chunksize=2)
        else:
            _init_worker(world, spec.seed, rays, bonnet, spec.ground_texture_scale)
            results = map(_render_one, frames)
        previous = None
        for i, (image, depth) in progress(zip(todo, results, strict=True), f"render {name}", len(todo), "frame"):
            with atomic_path(image_dir / f"{i:06d}.png") as tmp:
                cv2.imwrite(str(tmp), image)
            if spec.gt_flow:
                if previous is not None:
                    _write_gt_flow(directory, i - 1, previous, depth, poses, K, camera.distortion,
                                   None if bonnet is None else bonnet.mask)
                previous = depth
    return directory


def _write_gt_flow(directory: Path, index: int, depth: np.ndarray, depth_next: np.ndarray,
                   T_world_cam: np.ndarray, K: np.ndarray, distortion: LensDistortion,
                   still: np.ndarray | None = None) -> None:
    """True flow from frame ``index`` to the next; pixels of ``still`` (H, W) bool (a bonnet, fixed to the camera)
    do not move, and the scene moving under them is occluded where it reaches them."""
    T_next_cur = invert_se3(T_world_cam[index + 1]) @ T_world_cam[index]
    flow, next_depth = flow_from_depth(depth, K, T_next_cur, distortion)
    occluded = occlusion_mask(flow, next_depth, depth_next)
    if still is not None:
        flow[still] = 0.0
        occluded[still] = False
    flow_dir = directory / "flow_gt"
    flow_dir.mkdir(exist_ok=True)
    with atomic_path(flow_dir / f"{index:06d}.npy") as tmp:
        np.save(tmp, flow)
    with atomic_path(flow_dir / f"{index:06d}_occluded.png") as tmp:
        cv2.imwrite(str(tmp), occluded.astype(np.uint8) * 255)
    with atomic_path(flow_dir / f"{index:06d}_depth.npy") as tmp:
        np.save(tmp, depth.astype(np.float16))
