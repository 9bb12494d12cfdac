"""Flow as colour (the standard Middlebury colour wheel: hue = direction, saturation = magnitude).

For people only: the network always reads raw (u, v) floats, never these pictures.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from flowvo.io.atomic import atomic_path

# transitions of the Middlebury wheel: red-yellow, yellow-green, green-cyan, cyan-blue, blue-magenta, magenta-red
_SEGMENTS = (15, 6, 4, 11, 13, 6)


def color_wheel() -> np.ndarray:
    """The wheel's colours (55, 3), RGB in 0..1, starting at red and turning through yellow."""
    ramps = []
    keys = [(1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 1, 1), (0, 0, 1), (1, 0, 1), (1, 0, 0)]
    for (a, b, n) in zip(keys[:-1], keys[1:], _SEGMENTS, strict=True):
        f = np.arange(n)[:, None] / n
        ramps.append(np.asarray(a) * (1 - f) + np.asarray(b) * f)
    return np.concatenate(ramps)


def flow_to_color(flow_px: np.ndarray, max_magnitude_px: float | None = None) -> np.ndarray:
    """RGB uint8 (H, W, 3) picture of flow (H, W, 2); magnitude normalised by ``max_magnitude_px``
    (default: the 99th percentile of this field). NaN flow is drawn black."""
    u, v = flow_px[..., 0].astype(np.float64), flow_px[..., 1].astype(np.float64)
    invalid = ~(np.isfinite(u) & np.isfinite(v))
    u, v = np.where(invalid, 0, u), np.where(invalid, 0, v)
    magnitude = np.hypot(u, v)
    scale = max_magnitude_px or max(float(np.percentile(magnitude, 99)), 1e-6)
    radius = np.clip(magnitude / scale, 0, 1)
    wheel = color_wheel()
    angle = np.arctan2(-v, -u) / np.pi  # -1..1
    position = (angle + 1) / 2 * (len(wheel) - 1)
    k0 = np.floor(position).astype(int)
    k1 = (k0 + 1) % len(wheel)
    f = (position - k0)[..., None]
    colour = (1 - f) * wheel[k0] + f * wheel[k1]
    colour = 1 - radius[..., None] * (1 - colour)
    colour[invalid] = 0
    return np.clip(colour * 255 + 0.5, 0, 255).astype(np.uint8)


def color_legend(size_px: int = 101) -> np.ndarray:
    """A square RGB picture of the wheel: the flow at each pixel points from the centre to it."""
    r = size_px // 2
    v, u = np.mgrid[-r : r + 1, -r : r + 1].astype(np.float64)
    legend = flow_to_color(np.stack([u, v], -1), max_magnitude_px=float(r))
    legend[np.hypot(u, v) > r] = 255
    return legend


PICTURE_NAME = "flow_{:06d}.png"


def flow_picture_names(pairs: range, gif: bool) -> list[str]:
    """The files :func:`save_flow_pictures` writes for ``pairs``."""
    return [PICTURE_NAME.format(index) for index in pairs] + ["legend.png"] + (["flow.gif"] if gif else [])


def save_flow_pictures(flows, out_dir: str | Path, max_magnitude_px: float, gif: bool = False) -> list[Path]:
    """Write ``flow_NNNNNN.png`` per field of ``flows`` (an iterable of (index, flow)), ``legend.png`` and,
    optionally, ``flow.gif`` (10 fps, half size). All pictures share one magnitude scale."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written, frames = [], []
    for index, flow in flows:
        picture = flow_to_color(flow, max_magnitude_px)
        path = out / PICTURE_NAME.format(index)
        with atomic_path(path) as tmp:
            cv2.imwrite(str(tmp), cv2.cvtColor(picture, cv2.COLOR_RGB2BGR))
        written.append(path)
        if gif:
            frames.append(picture[::2, ::2])
    with atomic_path(out / "legend.png") as tmp:
        cv2.imwrite(str(tmp), cv2.cvtColor(color_legend(), cv2.COLOR_RGB2BGR))
    written.append(out / "legend.png")
    if gif and frames:
        from PIL import Image  # Pillow comes with matplotlib

        images = [Image.fromarray(frame) for frame in frames]
        with atomic_path(out / "flow.gif") as tmp:
            images[0].save(tmp, save_all=True, append_images=images[1:], duration=100, loop=0)
        written.append(out / "flow.gif")
    return written
