"""Render time per frame of the synthetic renderer, one core, full and half KITTI resolution.

Run: python benchmarks/bench_render.py
"""

import time

import cv2
import numpy as np
from _table import print_table

from flowvo.synth.camera_path import generate_path
from flowvo.synth.render import pixel_rays, render
from flowvo.synth.sequence_writer import intrinsics
from flowvo.synth.textures import make_textures
from flowvo.synth.world import SCENE_TYPES, build_world


def main() -> None:
    cv2.setNumThreads(1)
    poses = generate_path(300, 7)
    textures = make_textures(7)
    rows = []
    for scene in SCENE_TYPES:
        world = build_world(poses, 7, scene)
        for scale in (1.0, 0.5):
            rays = pixel_rays(*intrinsics(scale))
            times = []
            for pose in poses[::30]:
                start = time.perf_counter()
                render(world, textures, pose, rays)
                times.append(time.perf_counter() - start)
            rows.append([scene, f"{rays.size_hw[1]}x{rays.size_hw[0]}", float(np.median(times)), float(np.max(times))])
    print_table("synthetic render time per frame, 1 core (s)", ["scene", "size", "median_s", "max_s"], rows)


if __name__ == "__main__":
    main()
