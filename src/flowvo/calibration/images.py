"""The images a calibration reads: a folder of pictures or a video, as (label, grey image) pairs.

- Folder: its files ending in one of :data:`IMAGE_SUFFIXES` (any case), sorted by name; other files are
  ignored. Each is decoded from its bytes (``cv2.imdecode``), so no file name can trip OpenCV's path
  handling; a file that does not decode is an error naming it. Labels show names that are not UTF-8
  with ``\\xNN`` escapes, so they can always be printed.
- Video: any file OpenCV reads (:func:`flowvo.sources.video.open_video_source`); neighbouring frames are
  near-duplicates, so by default only every :data:`DEFAULT_VIDEO_EVERY`-th is looked at.
Images are read one at a time, as the calibration consumes them (a long video never sits in memory).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from flowvo.calibration.calibrate import MIN_VIEWS
from flowvo.errors import FlowvoError
from flowvo.sources.video import open_video_source

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
DEFAULT_VIDEO_EVERY = 15  # two frames a second of a 30 frames/s video: views a board held still repeats


@dataclass(frozen=True)
class CalibrationImages:
    """Where the images come from: ``frames()`` yields (label, grey image (H, W) uint8) pairs; ``count``
    is how many it will yield (None when a video does not state its length)."""

    path: Path
    files: tuple[Path, ...] | None  # None: a video
    every: int
    count: int | None

    def frames(self) -> Iterator[tuple[str, np.ndarray]]:
        if self.files is not None:
            for file in self.files:
                yield printable(file), read_grey_image(file)
            return
        for index, (_, image) in enumerate(open_video_source(self.path).frames()):
            if index % self.every == 0:
                yield f"{printable(self.path)} frame {index}", image


def open_calibration_images(path: str | Path, every: int | None = None) -> CalibrationImages:
    """The images of the folder or video at ``path``, every ``every``-th one (default: all of a folder,
    every :data:`DEFAULT_VIDEO_EVERY`-th frame of a video). One-line errors for a missing path, a folder
    without images, a single image and a file that is not a video."""
    path = Path(path)
    if every is not None and every < 1:
        raise FlowvoError(f"--every must be a positive number of images, got {every}")
    if path.is_dir():
        try:
            files = sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file())
        except OSError as error:
            raise FlowvoError(f"cannot read the folder: {error.strerror or error}", path) from None
        if not files:
            raise FlowvoError(f"no images ({' '.join(IMAGE_SUFFIXES)}) in this folder", path)
        chosen = tuple(files[:: every or 1])
        return CalibrationImages(path, chosen, every or 1, len(chosen))
    if not path.exists():
        raise FlowvoError("not found: give a folder of images or a video of the board", path)
    if path.suffix.lower() in IMAGE_SUFFIXES:
        raise FlowvoError(f"is a single image: give the folder holding all the views (at least {MIN_VIEWS})", path)
    video = open_video_source(path)
    every = every or DEFAULT_VIDEO_EVERY
    count = None if video.frame_count is None else -(-video.frame_count // every)
    return CalibrationImages(path, None, every, count)


def printable(path: Path) -> str:
    """``path`` as text that can always be printed: bytes of a name that is not UTF-8 as ``\\xNN``."""
    return str(path).encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def read_grey_image(path: Path) -> np.ndarray:
    """The grey image (H, W) uint8 in the file at ``path``; a one-line error when it does not decode."""
    try:
        data = np.fromfile(path, dtype=np.uint8)
    except OSError as error:
        raise FlowvoError(f"cannot be read: {error.strerror or error}", path) from None
    image = cv2.imdecode(data, cv2.IMREAD_GRAYSCALE) if data.size else None
    if image is None:
        raise FlowvoError("is not a readable image (empty, truncated or not an image)", path)
    return image
