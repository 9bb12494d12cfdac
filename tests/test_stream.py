"""The streaming pipeline gives exactly the poses of running the step's stages one after another."""

import threading

import numpy as np
import pytest

from flowvo.drive.stream import _read, stream_odometry
from flowvo.errors import FlowvoError
from flowvo.methods.base import NoWindow


class CountingStep(NoWindow):
    """A deterministic step: the motion depends on both frames, the times and the previous motions."""

    label = "test step"
    motion_stage = "geometry"
    opencv_threads = None

    def __init__(self) -> None:
        self.calls = 0

    def prepare(self, image):
        return image.astype(np.float64)

    def complete(self, prepared):
        return prepared

    def flow(self, previous, current):
        return float(current.mean() - previous.mean())

    def motion(self, times_s, previous, flow):
        self.calls += 1
        motion = np.eye(4)
        motion[0, 3] = flow * (times_s[1] - times_s[0]) + 0.01 * self.calls
        return motion


def frames(count=25):
    rng = np.random.default_rng(1)
    return [(0.1 * i + 0.003 * i * i, rng.integers(0, 255, (8, 12)).astype(np.uint8)) for i in range(count)]


@pytest.mark.parametrize("overlap", [True, False])
def test_stream_poses_equal_the_sequential_stages(overlap):
    result = stream_odometry(iter(frames()), CountingStep(), overlap=overlap)
    step, pose, expected = CountingStep(), np.eye(4), [np.eye(4)]
    data = frames()
    for (t0, a), (t1, b) in zip(data, data[1:], strict=False):
        pose = pose @ step.motion((t0, t1), None, step.flow(step.prepare(a), step.prepare(b)))
        expected.append(pose)
    np.testing.assert_array_equal(result.T_world_cam, np.stack(expected))
    np.testing.assert_array_equal(result.timestamps_s, [t for t, _ in data])
    assert result.frames == 25 and result.wall_seconds > 0


class CompletingStep(CountingStep):
    """CountingStep whose prepared frames need completing before their flow; records each completion's thread."""

    def __init__(self) -> None:
        super().__init__()
        self.completed_in: list[str] = []

    def prepare(self, image):
        return {"image": image, "mean": None}

    def complete(self, prepared):
        if prepared["mean"] is not None:
            return prepared
        self.completed_in.append(threading.current_thread().name)
        return {"image": prepared["image"], "mean": float(prepared["image"].mean())}

    def flow(self, previous, current):
        return current["mean"] - previous["mean"]


@pytest.mark.parametrize("overlap", [True, False])
def test_frames_completed_in_either_thread_give_the_sequential_poses(overlap):
    step = CompletingStep()
    result = stream_odometry(iter(frames()), step, overlap=overlap)
    plain = stream_odometry(iter(frames()), CountingStep(), overlap=False)
    np.testing.assert_array_equal(result.T_world_cam, plain.T_world_cam)
    assert len(step.completed_in) == 25  # each frame once
    assert threading.current_thread().name not in step.completed_in or not overlap


@pytest.mark.parametrize("busy", [True, False])
def test_the_reader_completes_frames_only_while_the_motion_thread_is_busy(busy):
    step = CompletingStep()
    prepared = [frame for _, frame, _ in _read(iter(frames(5)), step, None, lambda: busy)]
    assert [frame["mean"] is not None for frame in prepared] == [busy] * 5
    assert len(step.completed_in) == (5 if busy else 0)


class LateStep(CountingStep):
    """CountingStep whose window stage returns each motion two steps late, doubled in length."""

    latency_frames = 2

    def __init__(self) -> None:
        super().__init__()
        self.held: list = []

    def refine(self, time_s, motion, measured):
        doubled = motion.copy()
        doubled[0, 3] *= 2
        self.held.append((time_s, doubled))
        return [self.held.pop(0)] if len(self.held) > self.latency_frames else []

    def flush(self):
        held, self.held = self.held, []
        return held


@pytest.mark.parametrize("overlap", [True, False])
def test_a_late_window_stage_keeps_every_frame_in_order(overlap):
    result = stream_odometry(iter(frames()), LateStep(), overlap=overlap)
    plain = stream_odometry(iter(frames()), CountingStep(), overlap=overlap)
    steps = np.linalg.inv(plain.T_world_cam[:-1]) @ plain.T_world_cam[1:]
    late_steps = np.linalg.inv(result.T_world_cam[:-1]) @ result.T_world_cam[1:]
    np.testing.assert_allclose(late_steps[:, 0, 3], 2 * steps[:, 0, 3], rtol=1e-12)
    np.testing.assert_array_equal(result.timestamps_s, [t for t, _ in frames()])
    assert result.frames == 25 and result.stage_seconds["window"] >= 0


def test_max_frames_stops_early():
    assert stream_odometry(iter(frames()), CountingStep(), max_frames=5).frames == 5


def test_timestamps_that_do_not_increase_are_refused():
    data = frames(6)
    data[3] = (data[2][0], data[3][1])
    with pytest.raises(FlowvoError, match="timestamps must increase: frame 3"):
        stream_odometry(iter(data), CountingStep())


def test_an_error_in_the_source_reaches_the_caller():
    def broken():
        yield from frames(4)
        raise FlowvoError("cannot decode frame 4", "drive.avi")

    with pytest.raises(FlowvoError, match="drive.avi: cannot decode frame 4"):
        stream_odometry(broken(), CountingStep())


def test_an_empty_source_is_refused():
    with pytest.raises(FlowvoError, match="no frames"):
        stream_odometry(iter([]), CountingStep())
