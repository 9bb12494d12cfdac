"""Plan and write a synthetic dataset: which poses, seed and scene each sequence gets."""

from __future__ import annotations

from pathlib import Path

from flowvo.errors import FlowvoError
from flowvo.kitti.poses import read_kitti_poses
from flowvo.synth.camera_path import PathConfig, generate_path
from flowvo.synth.sequence_writer import SynthSpec, write_sequence

DEFAULT_FRAMES = 400


def sequence_seed(seed: int, name: str) -> int:
    """Each sequence gets its own world, deterministic per (seed, name)."""
    return seed * 1000 + sum(ord(c) * 31**i for i, c in enumerate(name)) % 997


def plan_sequence(name: str, seed: int, frames: int | None, trajectory: str | Path | None,
                  scale: float, scene: str | None, gt_flow: bool, max_speed_mps: float = 25.0) -> SynthSpec:
    """The spec of one sequence: a replay of ``trajectory`` (a pose file, or a folder of NN.txt) or a
    generated drive of ``frames`` frames."""
    world_seed = sequence_seed(seed, name)
    if trajectory is not None:
        path = Path(trajectory)
        if path.is_dir():
            path = path / f"{name}.txt"
        poses = read_kitti_poses(path)
        if not poses.is_complete:
            raise FlowvoError("a replayed trajectory needs every frame (12 numbers per line)", path)
        T = poses.T_world_cam[:frames] if frames else poses.T_world_cam
    else:
        T = generate_path(frames or DEFAULT_FRAMES, world_seed, PathConfig(max_speed_mps=max_speed_mps))
    if len(T) < 2:
        raise FlowvoError("a sequence needs at least 2 frames")
    return SynthSpec(T, world_seed, scale, scene, gt_flow)


def synthesize(root: str | Path, names: list[str], seed: int = 0, frames: int | None = None,
               trajectory: str | Path | None = None, scale: float = 1.0, scene: str | None = None,
               gt_flow: bool = False, workers: int | None = None, max_speed_mps: float = 25.0) -> list[Path]:
    """Write every named sequence under ``root`` in the KITTI layout; returns their folders."""
    return [
        write_sequence(root, name, plan_sequence(name, seed, frames, trajectory, scale, scene, gt_flow, max_speed_mps),
                       workers)
        for name in names
    ]
