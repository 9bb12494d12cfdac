"""A car's bonnet in the bottom rows of a synthetic frame, as a dash-cam sees it.

The bonnet is fixed to the camera: the same pixels in every frame, whatever the drive does. Its top edge curves a
little (highest in the middle of the image, ``EDGE_SAG`` of its rows lower at the image's sides); its paint is
textured (band-limited noise, so that corner detectors find points on it that stand still) and slightly shiny (a
soft highlight along the edge, brighter towards the middle). It is painted over the rendered scene in image space,
after the lens: the rows it covers are those of the distorted frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flowvo.synth.textures import band_limited_noise

EDGE_SAG = 0.35  # how much lower the edge lies at the image's sides than in its middle, a share of the bonnet's rows
PAINT_GREY = 0.24  # the paint's mean intensity (0..1): a dark car
PAINT_NOISE = 0.06  # the paint's texture, standard deviation (0..1)
HIGHLIGHT = 0.30  # the shine's peak intensity added (0..1), just below the edge in the middle
HIGHLIGHT_DEPTH = 0.25  # how far below the edge the shine reaches, a share of the bonnet's rows (1/e)
BONNET_DROP_M = 0.5  # the bonnet's surface below the camera (metres): its pixels' depth is where their rays meet it
MAX_BONNET_ROWS = 0.5  # a bonnet over more than half the image leaves too little road to drive on


@dataclass(frozen=True)
class Bonnet:
    """The bonnet of an (H, W) frame: ``mask`` (H, W) bool, True where it covers the scene; ``image`` (H, W)
    uint8, its grey values there (0 elsewhere); ``depth_m`` (H, W) float32, camera z of its surface (metres;
    ``inf`` elsewhere)."""

    mask: np.ndarray
    image: np.ndarray
    depth_m: np.ndarray

    def paint(self, image: np.ndarray, depth_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A rendered frame (H, W) uint8 and its depth (H, W) float32 with the bonnet over them (new arrays)."""
        return np.where(self.mask, self.image, image), np.where(self.mask, self.depth_m, depth_m).astype(np.float32)


def bonnet_mask(size_hw: tuple[int, int], share: float) -> np.ndarray:
    """The pixels (H, W) bool a bonnet covering the bottom ``share`` of the image height (in the middle) hides."""
    h, w = size_hw
    rows = share * h
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    across = (u - (w - 1) / 2.0) / ((w - 1) / 2.0 if w > 1 else 1.0)  # -1 at the left edge, +1 at the right
    edge_row = h - rows + EDGE_SAG * rows * across**2
    return (v >= edge_row) & (rows > 0)


def make_bonnet(size_hw: tuple[int, int], share: float, K: np.ndarray, seed: int) -> Bonnet:
    """The bonnet of a frame of ``size_hw`` with intrinsics ``K`` covering the bottom ``share`` of its height; its
    paint's texture is deterministic per ``seed``."""
    h, w = size_hw
    mask = bonnet_mask(size_hw, share)
    rows = max(share * h, 1.0)
    side = max(h, w)
    noise = band_limited_noise(np.random.default_rng(seed + 7919), side, 0.8, low_cut=6.0)[:h, :w]
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    across = (u - (w - 1) / 2.0) / ((w - 1) / 2.0 if w > 1 else 1.0)
    below_edge = v - (h - rows + EDGE_SAG * rows * across**2)  # rows below the edge
    shine = HIGHLIGHT * np.exp(-np.maximum(below_edge, 0.0) / (HIGHLIGHT_DEPTH * rows)) * (1.0 - 0.6 * across**2)
    grey = np.clip(PAINT_GREY + PAINT_NOISE * noise + shine, 0.0, 1.0)
    image = np.where(mask, np.clip(grey * 255.0 + 0.5, 0, 255), 0).astype(np.uint8)
    yn = (v - K[1, 2]) / K[1, 1]  # the rays' fall per unit depth (the bonnet lies below the principal point)
    depth = np.where(mask, BONNET_DROP_M / np.maximum(yn, 1e-3), np.inf)  # pinhole rays: an approximation
    return Bonnet(mask, image, depth.astype(np.float32))
