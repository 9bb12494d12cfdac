import logging

import cv2
import numpy as np
import pytest

from flowvo.drive.options import RunOptions, open_drive
from flowvo.errors import FlowvoError
from flowvo.sources import video as video_module
from flowvo.sources.video import next_timestamp_s, open_video_source

FPS = 12.5
SIZE_HW = (48, 80)


def colour_frames(count: int) -> list[np.ndarray]:
    """BGR frames (H, W, 3) uint8: a random texture shifting right by 2 px per frame, channels differing."""
    texture = np.random.default_rng(0).integers(0, 256, (SIZE_HW[0], SIZE_HW[1] + 2 * count, 3), dtype=np.uint8)
    return [np.ascontiguousarray(texture[:, 2 * i : 2 * i + SIZE_HW[1]]) for i in range(count)]


def write_video(path, frames: list[np.ndarray], fourcc: str = "FFV1") -> None:
    """A lossless FFV1 video (this OpenCV build's FFmpeg writes FFV1 in .avi and .mkv)."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), FPS, (SIZE_HW[1], SIZE_HW[0]))
    assert writer.isOpened()
    for frame in frames:
        writer.write(frame)
    writer.release()


@pytest.fixture
def video(tmp_path):
    frames = colour_frames(12)
    path = tmp_path / "my drive (1).avi"
    write_video(path, frames)
    return path, frames


def test_video_reads_back_grey_frames_sizes_and_container_timestamps(video):
    path, frames = video
    source = open_video_source(path)
    assert source.name == "my_drive__1_"
    assert source.image_size_hw == SIZE_HW and source.frame_count == 12 and source.frame_rate_hz == FPS
    assert source.camera is None and source.ground_truth is None and not source.is_synthetic
    read = list(source.frames())
    assert len(read) == 12
    times_s = np.array([t for t, _ in read])
    np.testing.assert_allclose(times_s, np.arange(12) / FPS, atol=1e-9)
    for (_, image), frame in zip(read, frames, strict=True):
        assert image.dtype == np.uint8 and image.shape == SIZE_HW
        np.testing.assert_array_equal(image, cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY))  # FFV1 is lossless
    assert len(list(source.frames())) == 12  # each call decodes from the start


def test_missing_file_is_refused(tmp_path):
    with pytest.raises(FlowvoError, match="absent.mp4: video file not found"):
        open_video_source(tmp_path / "absent.mp4")


@pytest.mark.parametrize("content", [b"", b"not a video\n" * 20])
def test_empty_or_text_file_is_refused(tmp_path, content):
    (tmp_path / "clip.avi").write_bytes(content)
    with pytest.raises(FlowvoError, match="clip.avi: OpenCV cannot open this file as a video"):
        open_video_source(tmp_path / "clip.avi")


def test_truncated_file_ends_at_its_last_good_frame_with_a_warning(video, caplog):
    path, frames = video
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    source = open_video_source(path)  # the first frames still decode
    with caplog.at_level(logging.WARNING, logger="flowvo.sources.video"):
        read = list(source.frames())
    assert 1 <= len(read) < 12
    np.testing.assert_array_equal(read[-1][1], cv2.cvtColor(frames[len(read) - 1], cv2.COLOR_BGR2GRAY))
    assert len(source.warnings) == 1 and source.warnings == [caplog.records[0].getMessage().removeprefix("warning: ")]
    assert f"my drive (1).avi: decoding stopped after {len(read)} of the 12 frames" in source.warnings[0]
    list(source.frames())
    assert len(source.warnings) == 1  # each read says it once


def test_missing_intrinsics_of_a_video_too_small_to_estimate_them_are_refused(video):
    path, _ = video
    with pytest.raises(FlowvoError, match=r"\(1\).avi: no camera intrinsics, and the focal length cannot be "
                                          r"estimated from the motion in the first 12 frames: .* give --calib"):
        open_drive(RunOptions(out="unused", video=str(path)))


def test_principal_point_outside_the_frame_is_refused(video):
    path, _ = video
    options = RunOptions(out="unused", video=str(path), fx=70.0, fy=70.0, cx=120.0, cy=23.5)
    with pytest.raises(FlowvoError, match=r"principal point \(120.0, 23.5\) lies outside the 80x48"):
        open_drive(options)


def test_missing_or_repeated_container_times_fall_back_to_the_frame_rate():
    assert next_timestamp_s(1500.0, None, FPS) == 1.5  # container time as it is, also for the first frame
    assert next_timestamp_s(0.0, None, None) == 0.0
    assert next_timestamp_s(1600.0, 1.5, FPS) == 1.6
    assert next_timestamp_s(1500.0, 1.5, FPS) == pytest.approx(1.58)  # repeated
    assert next_timestamp_s(0.0, 1.5, FPS) == pytest.approx(1.58)  # missing (raw streams report 0)
    assert next_timestamp_s(float("nan"), 1.5, FPS) == pytest.approx(1.58)
    assert next_timestamp_s(0.0, 1.5, None) is None  # no frame rate to fall back on: the caller raises


class WithoutContainerTimes:
    """A capture whose container reports time 0 for every frame, as raw streams do."""

    def __init__(self, path):
        self.capture = cv2.VideoCapture(str(path))

    def read(self):
        return self.capture.read()

    def get(self, prop):
        return 0.0 if prop == cv2.CAP_PROP_POS_MSEC else self.capture.get(prop)

    def release(self):
        self.capture.release()


def test_stream_without_container_times_is_timed_by_the_frame_rate_with_one_warning(video, monkeypatch, caplog):
    path, _ = video
    source = open_video_source(path)
    monkeypatch.setattr(video_module, "_open_capture", WithoutContainerTimes)
    with caplog.at_level(logging.WARNING, logger="flowvo.sources.video"):
        times_s = [t for t, _ in source.frames()]
    np.testing.assert_allclose(times_s, np.arange(12) / FPS, atol=1e-9)
    assert len(caplog.records) == 1 and "frame 1 has no increasing container timestamp" in caplog.text
