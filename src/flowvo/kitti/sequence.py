"""Lazy reader for one sequence of the KITTI odometry layout (real or synthetic: one code path).

Layout: ``<root>/sequences/NN/image_{0,1,2,3}/NNNNNN.png``, ``calib.txt``, ``times.txt`` and
``<root>/poses/NN.txt`` (optional: the test sequences 11-21 have none).
"""

from __future__ import annotations

import math
import re
import struct
from functools import cached_property
from pathlib import Path

import cv2
import numpy as np

from flowvo.errors import FlowvoError
from flowvo.io.outputs import check_path_text, validate_name
from flowvo.io.text_numbers import parse_float
from flowvo.kitti.calib import Calibration, read_calibration
from flowvo.kitti.poses import read_kitti_poses
from flowvo.trajectory import MIN_FRAME_INTERVAL_S, Trajectory

_FRAME_NAME = re.compile(r"^(\d{6})\.png$")
CAMERAS = ("image_0", "image_1", "image_2", "image_3")


def png_size(path: Path) -> tuple[int, int]:
    """(height, width) read from a PNG header without decoding the image."""
    with open(path, "rb") as handle:
        header = handle.read(24)
    if len(header) < 24 or header[:8] != b"\x89PNG\r\n\x1a\n" or header[12:16] != b"IHDR":
        raise FlowvoError("not a PNG image", path)
    width, height = struct.unpack(">II", header[16:24])
    return int(height), int(width)


def sequence_name(name: str) -> str:
    """The canonical name of a sequence: a plain name (see :func:`flowvo.io.outputs.validate_name`), digits
    zero-padded to two as KITTI names them (``9`` -> ``09``, ``000`` -> ``00``)."""
    text = validate_name(name)
    return f"{int(text):02d}" if text.isdigit() else text


class KittiSequence:
    """One odometry sequence. Frames are read on demand, in order, never all at once.

    Validation on opening: the camera folder exists, frame files are 000000.png .. consecutively,
    every image has the same size, times.txt and the pose file (when present) have one line per frame.
    """

    def __init__(self, root: str | Path, sequence: str, camera: str = "image_0") -> None:
        self.root = check_path_text(root, "dataset root")  # OpenCV crashes the process on non-UTF-8 names
        self.sequence = sequence_name(sequence)
        if camera not in CAMERAS:
            raise FlowvoError(f"unknown camera {camera!r}; expected one of {', '.join(CAMERAS)}")
        self.camera = camera
        self.directory = self.root / "sequences" / self.sequence
        if not self.directory.is_dir():
            raise FlowvoError("sequence folder not found (expected <root>/sequences/NN)", self.directory)
        self.image_paths = self._list_frames(self.directory / camera)
        self.image_size_hw = self._check_sizes(self.image_paths)
        self.times_s = self._read_times(self.directory / "times.txt", len(self.image_paths))

    @staticmethod
    def _list_frames(image_dir: Path) -> list[Path]:
        if not image_dir.is_dir():
            raise FlowvoError("image folder not found", image_dir)
        numbered: list[tuple[int, Path]] = []
        for path in image_dir.iterdir():
            match = _FRAME_NAME.match(path.name)
            if match is None:  # hidden files (e.g. a killed writer's .000004.x1y2.png) are never frames
                if path.suffix.lower() == ".png" and not path.name.startswith("."):
                    raise FlowvoError("frame file name must be six digits, e.g. 000000.png", path)
                continue
            numbered.append((int(match.group(1)), path))
        if not numbered:
            raise FlowvoError("no frames (expected 000000.png ...)", image_dir)
        numbered.sort()
        for expected, (number, path) in enumerate(numbered):
            if number != expected:
                raise FlowvoError(f"frame {expected:06d}.png is missing (frames must be consecutive)", path.parent)
        return [path for _, path in numbered]

    @staticmethod
    def _check_sizes(paths: list[Path]) -> tuple[int, int]:
        first = png_size(paths[0])
        for path in paths[1:]:
            size = png_size(path)
            if size != first:
                raise FlowvoError(f"image is {size[1]}x{size[0]}, the sequence's first is {first[1]}x{first[0]}", path)
        return first

    @staticmethod
    def _read_times(path: Path, n_frames: int) -> np.ndarray:
        if not path.is_file():
            raise FlowvoError("times.txt not found", path)
        values: list[float] = []
        with open(path, encoding="utf-8-sig", errors="replace") as handle:  # -sig: a byte-order mark is no text
            for line_number, line in enumerate(handle, start=1):
                if not line.strip():
                    continue
                try:
                    values.append(parse_float(line.strip()))
                except ValueError:
                    raise FlowvoError("expected one timestamp in seconds per line", path, line_number) from None
                if not math.isfinite(values[-1]):
                    raise FlowvoError("timestamp is not a finite number of seconds", path, line_number)
                if len(values) > 1 and values[-1] <= values[-2]:
                    raise FlowvoError("timestamps must increase; this one does not", path, line_number)
                if len(values) > 1 and values[-1] - values[-2] < MIN_FRAME_INTERVAL_S:
                    raise FlowvoError(f"timestamp {values[-1] - values[-2]:.3g} s after the previous one: frames "
                                      f"must be at least {MIN_FRAME_INTERVAL_S:g} s apart (times in seconds?)", path,
                                      line_number)
        if len(values) != n_frames:
            raise FlowvoError(f"has {len(values)} timestamps for {n_frames} frames", path)
        return np.asarray(values)

    def __len__(self) -> int:
        return len(self.image_paths)

    def require_frames(self, minimum: int, purpose: str) -> None:
        """Raise a :class:`FlowvoError` unless the sequence has at least ``minimum`` frames; ``purpose``
        (e.g. "odometry") says in the message what needs them."""
        if len(self) < minimum:
            raise FlowvoError(f"has {len(self)} frame(s); {purpose} needs at least {minimum}",
                              self.directory / self.camera)

    @cached_property
    def calibration(self) -> Calibration:
        """The sequence's calib.txt."""
        return read_calibration(self.directory / "calib.txt")

    @property
    def pose_path(self) -> Path:
        """Where the ground-truth poses of this sequence live (they may not exist)."""
        return self.root / "poses" / f"{self.sequence}.txt"

    @property
    def has_poses(self) -> bool:
        """True when ground-truth poses exist for this sequence."""
        return self.pose_path.is_file()

    @cached_property
    def poses(self) -> Trajectory:
        """Ground-truth camera-to-world poses, one per frame; raises when absent or of the wrong length."""
        trajectory = read_kitti_poses(self.pose_path)
        if len(trajectory) != len(self) or not trajectory.is_complete:
            raise FlowvoError(f"has {len(trajectory)} poses for {len(self)} frames", self.pose_path)
        return trajectory

    @property
    def is_synthetic(self) -> bool:
        """True for sequences rendered by ``flowvo synth`` (they carry a synthetic.json)."""
        return (self.directory / "synthetic.json").is_file()

    def read_image(self, index: int, color: bool = False) -> np.ndarray:
        """Frame ``index`` as uint8, (H, W) grey or (H, W, 3) BGR."""
        path = self.image_paths[index]
        image = cv2.imread(str(path), cv2.IMREAD_COLOR if color else cv2.IMREAD_GRAYSCALE)
        if image is None:
            raise FlowvoError("cannot decode image", path)
        return image

    def images(self, color: bool = False, start: int = 0):
        """The frames' images in order, each read when it is reached (without times: the frame source of
        a sequence, :class:`flowvo.sources.kitti_folder.KittiFolderSource`, yields both)."""
        for index in range(start, len(self)):
            yield self.read_image(index, color)
