"""A small fleet for the batch tests: two synthetic KITTI sequences, a lossless video of sequence 00's
frames (same poses as the sequence), and a file that only looks like a video."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2

from flowvo.kitti.sequence import KittiSequence
from flowvo.synth.dataset import synthesize

FRAMES = 10


@dataclass(frozen=True)
class Fleet:
    kitti: Path  # dataset root with sequences 00 and 01
    videos: Path  # folder with good.avi (the frames of 00) and broken.mp4 (random bytes)
    calib: Path  # intrinsics of the videos

    @property
    def good_video(self) -> Path:
        return self.videos / "good.avi"

    @property
    def broken_video(self) -> Path:
        return self.videos / "broken.mp4"


def write_video(path: Path, root: Path, sequence: str = "00", repeat: int = 1) -> Path:
    """The frames of ``root``'s ``sequence`` (``repeat`` times over) as a lossless FFV1 video at 10 frames/s."""
    frames = list(KittiSequence(root, sequence).images()) * repeat
    h, w = frames[0].shape
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), 10.0, (w, h))
    for frame in frames:
        writer.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR))
    writer.release()
    return path


def make_fleet(folder: Path) -> Fleet:
    kitti = folder / "kitti"
    synthesize(kitti, ["00", "01"], seed=4, frames=FRAMES, scale=0.25, workers=1)  # 310x94: even, for codecs
    videos = folder / "videos"
    videos.mkdir()
    write_video(videos / "good.avi", kitti)
    (videos / "broken.mp4").write_bytes(b"\x00\x00\x00\x18ftypmp42" + bytes(range(256)) * 8)
    return Fleet(kitti, videos, kitti / "sequences" / "00" / "calib.txt")
