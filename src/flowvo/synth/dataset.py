"""Plan and write a synthetic dataset: which poses, seed and scene each sequence gets."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from flowvo.errors import FlowvoError
from flowvo.io.outputs import check_path_text
from flowvo.kitti.poses import read_kitti_poses
from flowvo.kitti.sequence import sequence_name
from flowvo.synth.camera_path import PathConfig, generate_path
from flowvo.synth.frame_rate import frames_spanning, path_frames_for
from flowvo.synth.replay_path import consistent_heights, drivable_heights, levelled
from flowvo.synth.sequence_writer import SynthSpec, intrinsics, spec_digest, write_sequence
from flowvo.synth.synth_camera import PATH_RATE_HZ, SynthCamera, check_lens
from flowvo.synth.textures import GROUND_TEXTURE_SCALE_RANGE

DEFAULT_FRAMES = 400
MAX_SCALE = 4.0  # 4964 x 1504 frames; beyond that a render needs more memory than a laptop has
MIN_IMAGE_PX = 16


def sequence_seed(seed: int, name: str) -> int:
    """Each sequence gets its own world, deterministic per (seed, name)."""
    return seed * 1000 + sum(ord(c) * 31**i for i, c in enumerate(name)) % 997


def plan_sequence(name: str, seed: int, frames: int | None, trajectory: str | Path | None,
                  scale: float, scene: str | None, gt_flow: bool, max_speed_mps: float = 25.0,
                  camera: SynthCamera | None = None, ground_texture_scale: float = 1.0) -> SynthSpec:
    """The spec of one sequence: a replay of ``trajectory`` (a pose file, or a folder of NN.txt) or a
    generated drive, of ``frames`` frames at the camera's frame rate (default: the whole replay, or a
    generated drive of DEFAULT_FRAMES / 10 Hz seconds). The drive is a 10 Hz path either way; other frame
    rates sample it in time (see :mod:`flowvo.synth.frame_rate`). ``ground_texture_scale``: the ground's texture that
    many times finer than by default."""
    camera = camera or SynthCamera()
    _check_scale(scale, camera)
    if gt_flow and camera.readout_ms:
        raise FlowvoError("--gt-flow: the true flow is written for a global shutter; leave out --readout-ms")
    if frames is not None and frames < 2:
        raise FlowvoError(f"--frames {frames}: a sequence needs at least 2 frames")
    if seed < 0 or not 0 < max_speed_mps <= 100:
        raise FlowvoError(f"--seed {seed} must be >= 0 and --max-speed {max_speed_mps:g} in (0, 100] m/s")
    low, high = GROUND_TEXTURE_SCALE_RANGE
    if not low <= ground_texture_scale <= high:
        raise FlowvoError(f"--ground-texture-scale {ground_texture_scale:g}: use a scale in [{low:g}, {high:g}]")
    world_seed = sequence_seed(seed, name)
    path_frames = None if frames is None else path_frames_for(frames, PATH_RATE_HZ, camera.fps)
    if trajectory is not None:
        path = Path(trajectory)
        if path.is_dir():
            path = path / f"{name}.txt"
        poses = read_kitti_poses(path)
        if not poses.is_complete:
            raise FlowvoError("a replayed trajectory needs every frame (12 numbers per line)", path)
        T = poses.T_world_cam if frames is None else poses.T_world_cam[:path_frames]
        if frames is not None and len(T) < path_frames:
            frames = frames_spanning(len(T), PATH_RATE_HZ, camera.fps)  # a short replay: all of it
        if len(T) < 2:
            raise FlowvoError(f"holds {len(T)} pose; a replayed sequence needs at least 2 frames", path)
        T = consistent_heights(drivable_heights(levelled(T)))  # its world is built level, along heights a car can
        # drive, one height where it passes again; the pose file is written relative to the first camera
    else:
        T = generate_path(DEFAULT_FRAMES if frames is None else path_frames, world_seed,
                          PathConfig(max_speed_mps=max_speed_mps))
    return SynthSpec(T, world_seed, scale, scene, gt_flow, camera, frames, ground_texture_scale)


def _check_scale(scale: float, camera: SynthCamera) -> None:
    if not 0 < scale <= MAX_SCALE:
        raise FlowvoError(f"--scale {scale:g}: use a scale in (0, {MAX_SCALE:g}] (1.0 = KITTI's 1241x376)")
    K, (height, width) = intrinsics(scale, camera)
    if min(height, width) < MIN_IMAGE_PX:
        raise FlowvoError(f"--scale {scale:g} gives {width}x{height} images; need at least {MIN_IMAGE_PX} pixels "
                          "a side")
    check_lens(camera.distortion, K, (height, width))


def _existing_digest(root: Path, name: str) -> str | None:
    """The spec digest recorded by an earlier ``flowvo synth`` of this sequence, or None."""
    try:
        return json.loads((root / "sequences" / name / "synthetic.json").read_text()).get("spec_sha256")
    except (OSError, ValueError, AttributeError):
        return None


def _clear_sequence(root: Path, name: str) -> None:
    """Remove an earlier synthetic sequence (frames, calib, times, GT flow) and its pose file (--force)."""
    directory = root / "sequences" / name
    if directory.exists():
        shutil.rmtree(directory)
    (root / "poses" / f"{name}.txt").unlink(missing_ok=True)


DATASET_ENTRIES = ("sequences", "poses")  # what a KITTI-layout root holds; other sequences there are kept


def _present(root: Path, name: str) -> bool:
    """True when ``root`` holds anything of sequence ``name`` (its folder or its pose file)."""
    return (root / "sequences" / name).exists() or (root / "poses" / f"{name}.txt").exists()


def check_target(root: Path, specs: dict[str, SynthSpec], force: bool) -> list[str]:
    """Refuse to mix a new rendering with what ``root`` holds; returns the sequences to clear first.

    ``root`` may be absent, empty, or a dataset (only ``sequences/`` and ``poses/``) holding other
    sequences. A named sequence already there is resumed when its synthetic.json records this same spec
    (frames on disk are reused); rendered differently, it is replaced whole with ``force`` only, and never
    when flowvo synth did not write it (its own frames or pose file are the user's). Other content of a
    non-empty root needs ``force`` (and is kept).
    """
    if root.exists() and not root.is_dir():
        raise FlowvoError("--out is a file, expected a folder", root)
    others = sorted(entry.name for entry in root.iterdir() if entry.name not in DATASET_ENTRIES) \
        if root.is_dir() else []
    if others and not force:
        raise FlowvoError(f"is not empty and not a dataset root (holds {', '.join(others[:3])}); use an empty "
                          "folder or a dataset root, or --force to write beside that content (it is kept)", root)
    stale = [name for name, spec in specs.items()
             if _present(root, name) and _existing_digest(root, name) != spec_digest(spec)]
    for name in stale:
        if not (root / "sequences" / name / "synthetic.json").is_file():
            raise FlowvoError(f"holds a sequence {name} not written by flowvo synth (no synthetic.json); not "
                              "replacing it even with --force: choose another --out or sequence name", root)
    if stale and not force:
        raise FlowvoError(f"holds sequence(s) {' '.join(stale)} rendered differently before; synth refuses to mix "
                          "old frames with new poses: use another folder or sequence name, or --force to replace "
                          "them whole (other sequences are kept)", root)
    return stale


def synthesize(root: str | Path, names: list[str], seed: int = 0, frames: int | None = None,
               trajectory: str | Path | None = None, scale: float = 1.0, scene: str | None = None,
               gt_flow: bool = False, workers: int | None = None, max_speed_mps: float = 25.0,
               force: bool = False, camera: SynthCamera | None = None, ground_texture_scale: float = 1.0
               ) -> list[Path]:
    """Write every named sequence under ``root`` in the KITTI layout, seen by ``camera`` (KITTI's by
    default), the ground's texture ``ground_texture_scale`` times finer than by default; returns their folders.

    Every plan is made (and every input read) before anything is written; see :func:`check_target` for
    when an existing ``root`` is refused, resumed or (``force``) partly replaced.
    """
    root = check_path_text(root, "--out")  # OpenCV crashes the process writing frames under non-UTF-8 names
    canonical = [sequence_name(name) for name in names]
    repeated = sorted({name for name in canonical if canonical.count(name) > 1})
    if repeated:
        raise FlowvoError(f"sequence {' '.join(repeated)} given more than once")
    specs = {name: plan_sequence(name, seed, frames, trajectory, scale, scene, gt_flow, max_speed_mps, camera,
                                ground_texture_scale)
             for name in canonical}
    for name in check_target(root, specs, force):
        _clear_sequence(root, name)
    return [write_sequence(root, name, spec, workers) for name, spec in specs.items()]
