"""Sampling an image at arbitrary point lists with OpenCV's remap (the renderer's one lookup primitive)."""

from __future__ import annotations

import cv2
import numpy as np

_FOLD_COLS = 1024  # remap needs destination sides below 32767, so long point lists are folded into rows


def sample_points(image: np.ndarray, col: np.ndarray, row: np.ndarray, interpolation: int = cv2.INTER_LINEAR,
                  border_mode: int = cv2.BORDER_REPLICATE) -> np.ndarray:
    """Values of ``image`` at fractional pixel coordinates (any shape, same for both), that shape back."""
    shape = np.shape(col)
    n = int(np.prod(shape))
    rows = max(1, -(-n // _FOLD_COLS))
    map_c = np.zeros(rows * _FOLD_COLS, np.float32)
    map_r = np.zeros(rows * _FOLD_COLS, np.float32)
    map_c[:n] = np.ravel(col)
    map_r[:n] = np.ravel(row)
    sampled = cv2.remap(image, map_c.reshape(rows, _FOLD_COLS), map_r.reshape(rows, _FOLD_COLS), interpolation,
                        borderMode=border_mode)
    return sampled.reshape(-1)[:n].reshape(shape)
