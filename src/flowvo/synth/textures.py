"""Procedural, tileable textures with mip pyramids, sampled by surface coordinates in metres.

Every texture is band-limited noise (random phases, a power-law spectrum) plus structure (windows,
leaves, clouds), so optical flow finds detail at several scales, and it is filtered by distance
(trilinear mip-mapping) so that far surfaces do not alias into flicker.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from flowvo.synth.sampling import sample_points

TEXTURE_SIZE = 512
GROUND_TEXTURE_SCALE_RANGE = (0.25, 4.0)  # how much finer than by default the ground's texture may be: the asphalt's
# finest detail from 9 cm down to 6 mm


def band_limited_noise(rng: np.random.Generator, size: int, exponent: float, low_cut: float = 2.0) -> np.ndarray:
    """Periodic noise (size, size), zero mean, unit std, amplitude spectrum ~ 1 / f**exponent."""
    fy = np.fft.fftfreq(size)[:, None] * size
    fx = np.fft.rfftfreq(size)[None, :] * size
    radius = np.sqrt(fx**2 + fy**2)
    amplitude = np.where(radius >= low_cut, 1.0 / np.maximum(radius, 1.0) ** exponent, 0.0)
    phases = rng.uniform(0, 2 * np.pi, amplitude.shape)
    field = np.fft.irfft2(amplitude * np.exp(1j * phases), s=(size, size))
    return ((field - field.mean()) / field.std()).astype(np.float32)


def _periodic_pyr_down(image: np.ndarray) -> np.ndarray:
    """Half-size Gaussian pyramid level of a tileable image, wrapping at the borders."""
    return cv2.pyrDown(np.pad(image, 4, mode="wrap"))[2:-2, 2:-2]


@dataclass(frozen=True)
class Texture:
    """A tileable intensity texture (values ~0..1) with ``texel_m`` metres per texel at level 0."""

    levels: tuple[np.ndarray, ...]
    texel_m: float

    @classmethod
    def from_image(cls, image: np.ndarray, texel_m: float) -> Texture:
        levels = [np.clip(image, 0.0, 1.0).astype(np.float32)]
        while levels[-1].shape[0] > 8:
            levels.append(_periodic_pyr_down(levels[-1]))
        return cls(tuple(levels), texel_m)

    def sample(self, s_m: np.ndarray, t_m: np.ndarray, footprint_m: np.ndarray) -> np.ndarray:
        """Intensity at surface coordinates (metres), blurred to a pixel footprint (metres), trilinear."""
        level = np.clip(np.log2(np.maximum(footprint_m, 1e-6) / self.texel_m), 0, len(self.levels) - 1.001)
        base = np.floor(level).astype(np.int32)
        frac = (level - base).astype(np.float32)
        out = np.empty(s_m.shape, np.float32)
        for lvl in np.unique(base):
            idx = np.flatnonzero(base == lvl)
            lower = self._sample_level(int(lvl), s_m.ravel()[idx], t_m.ravel()[idx])
            upper = self._sample_level(int(lvl) + 1, s_m.ravel()[idx], t_m.ravel()[idx])
            f = frac.ravel()[idx]
            out.ravel()[idx] = lower * (1 - f) + upper * f
        return out

    def _sample_level(self, level: int, s_m: np.ndarray, t_m: np.ndarray) -> np.ndarray:
        image = self.levels[level]
        size = image.shape[0]
        scale = size / (TEXTURE_SIZE * self.texel_m)
        return sample_points(image, np.mod(s_m * scale, size), np.mod(t_m * scale, size),
                             border_mode=cv2.BORDER_WRAP)


def make_textures(seed: int, ground_texture_scale: float = 1.0) -> dict[str, Texture]:
    """The texture set of a world, deterministic per seed; the ground's (asphalt and grass) ``ground_texture_scale``
    times finer than by default (the same pattern over a patch that many times smaller: a camera ``1 / scale`` as
    high then sees it in pixels as a camera at the default height sees the default; 1: the asphalt's finest detail
    is 2.3 cm, the grass's 3.1 cm)."""
    rng = np.random.default_rng(seed)
    n = TEXTURE_SIZE
    fine = [band_limited_noise(rng, n, e) for e in (0.6, 1.0, 1.5, 2.0)]
    yy, xx = np.mgrid[0:n, 0:n] / n
    # facade: window grid (3.2 m x 3.0 m cells at 10 m tile) over plaster noise
    window = ((np.mod(xx * 10 / 3.2 * 3, 1.0) > 0.3) & (np.mod(yy * 10 / 3.0 * 3, 1.0) > 0.45)).astype(np.float32)
    window = cv2.GaussianBlur(np.pad(window, 8, mode="wrap"), (0, 0), 1.0)[8:-8, 8:-8]
    facade = 0.55 + 0.08 * fine[1] + 0.05 * fine[0] - 0.3 * window * (0.8 + 0.2 * fine[3])
    brick = 0.45 + 0.1 * fine[0] + 0.06 * fine[2] + 0.05 * (np.mod(yy * 80, 1.0) < 0.12)
    asphalt = 0.30 + 0.05 * fine[0] + 0.05 * fine[1] + 0.04 * fine[3]
    grass = 0.52 + 0.09 * fine[0] + 0.08 * fine[2] + 0.05 * fine[3]
    foliage = 0.30 + 0.14 * fine[0] + 0.1 * fine[1]
    bark = 0.35 + 0.08 * fine[0] + 0.08 * np.sin(xx * 2 * np.pi * 40 + 2 * fine[3])
    clouds = 0.8 + 0.05 * fine[3] + 0.03 * fine[2]
    hills = 0.38 + 0.07 * fine[2] + 0.06 * fine[3]
    return {
        "facade": Texture.from_image(facade, 10.0 / n),
        "brick": Texture.from_image(brick, 8.0 / n),
        "asphalt": Texture.from_image(asphalt, 12.0 / n / ground_texture_scale),
        "grass": Texture.from_image(grass, 16.0 / n / ground_texture_scale),
        "foliage": Texture.from_image(foliage, 6.0 / n),
        "bark": Texture.from_image(bark, 4.0 / n),
        "sky": Texture.from_image(clouds, 1.0 / n),  # sampled in radians of azimuth/elevation
        "hills": Texture.from_image(hills, 1.0 / n),
    }
