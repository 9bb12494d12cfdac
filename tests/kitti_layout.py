"""Builds tiny KITTI-layout folders for reader tests."""

from pathlib import Path

import cv2
import numpy as np


def make_sequence(root: Path, n_frames: int = 3, size_hw: tuple[int, int] = (8, 12), sequence: str = "00") -> Path:
    seq = root / "sequences" / sequence
    (seq / "image_0").mkdir(parents=True)
    for i in range(n_frames):
        cv2.imwrite(str(seq / "image_0" / f"{i:06d}.png"), np.full(size_hw, i * 10, np.uint8))
    (seq / "times.txt").write_text("".join(f"{0.1 * i:.6e}\n" for i in range(n_frames)))
    p = "7.0e+02 0 6.0e+02 0 0 7.0e+02 1.8e+02 0 0 0 1 0"
    p1 = "7.0e+02 0 6.0e+02 -3.78e+02 0 7.0e+02 1.8e+02 0 0 0 1 0"
    (seq / "calib.txt").write_text(f"P0: {p}\nP1: {p1}\nP2: {p}\nP3: {p}\n")
    (root / "poses").mkdir(exist_ok=True)
    (root / "poses" / f"{sequence}.txt").write_text("1 0 0 0 0 1 0 0 0 0 1 0\n" * n_frames)
    return seq
