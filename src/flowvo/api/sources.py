"""What the Python API runs on: a drive named by a path (a KITTI folder, a video, a ROS bag) as ``flowvo run``
opens it, frames from any iterable of ``(time_s, image)``, and the frames pushed one at a time; and the
:class:`flowvo.drive.options.RunOptions` that say the same to the command line's machinery."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from flowvo.api.frames import FrameChecks
from flowvo.camera import Camera as InternalCamera
from flowvo.drive.options import Drive, RunOptions
from flowvo.errors import FlowvoError
from flowvo.io.outputs import validate_name
from flowvo.methods import DEFAULT_METHOD, method
from flowvo.trajectory import Trajectory

BAG_SUFFIXES = (".bag", ".mcap", ".db3")


def run_options(camera: InternalCamera | None, method_name: str = DEFAULT_METHOD, *, model: str | None = None,
                flow_method: str | None = None, latency_frames: int | None = None, **fields: Any) -> RunOptions:
    """The :class:`RunOptions` of a run with ``camera`` (None: the drive's own) and the method's options; ``fields``:
    the drive (``data``/``sequence``, ``video``, ``bag``/``topic``, ``max_frames``, ``overlap_stages``)."""
    method(method_name)  # a one-line error for an unknown name, before anything is opened
    if camera is not None and not isinstance(camera, InternalCamera):
        raise FlowvoError(f"camera must be a flowvo.Camera (flowvo.Camera(fx, fy, cx, cy) or "
                          f"flowvo.Camera.from_file(path)), got {type(camera).__name__}")
    if camera is None:
        camera_fields = {}
    elif hasattr(camera, "run_options"):
        camera_fields = camera.run_options()
    else:  # an internal camera: its numbers, as flags
        distortion = None if camera.distortion.is_none else camera.distortion.coefficients
        i = camera.intrinsics
        camera_fields = {"fx": i.fx, "fy": i.fy, "cx": i.cx, "cy": i.cy, "distortion": distortion,
                         "distortion_model": None if distortion is None else camera.distortion.model,
                         "camera_height_m": camera.height_m, "camera_pitch_deg": camera.pitch_deg,
                         "camera_roll_deg": camera.roll_deg, "readout_ms": camera.readout_ms}
    return RunOptions(out="", method=method_name, model=model, flow_method=flow_method, latency_frames=latency_frames,
                      **camera_fields, **fields)


def path_fields(source: str | Path, sequence: str | None, topic: str | None,
                camera_info_topic: str | None) -> dict[str, Any]:
    """The drive fields of :class:`RunOptions` for a path: a KITTI dataset root (with ``sequence``, or its only
    sequence), a KITTI sequence folder (``ROOT/sequences/NN``), a ROS bag (``.bag``, ``.mcap``, a ROS 2 bag folder;
    with ``topic``) or a video file."""
    path = Path(source)
    if not path.exists():
        raise FlowvoError("not found (give a KITTI folder, a video file, a ROS bag, or an iterable of (time_s, "
                          "image))", path)
    is_bag = path.suffix.lower() in BAG_SUFFIXES or (path.is_dir() and (path / "metadata.yaml").is_file())
    if is_bag:
        if topic is None:
            raise FlowvoError("a bag needs topic='/camera/image_raw' (its image topic)", path)
        return {"bag": str(path), "topic": topic, "camera_info_topic": camera_info_topic}
    if path.is_file():
        return {"video": str(path)}
    if (path / "sequences").is_dir():
        if sequence is None:
            names = sorted(entry.name for entry in (path / "sequences").iterdir() if entry.is_dir())
            if len(names) != 1:
                raise FlowvoError(f"holds sequences {', '.join(names) or '(none)'}: give sequence='NN'", path)
            sequence = names[0]
        return {"data": str(path), "sequence": validate_name(sequence)}
    if path.parent.name == "sequences":
        if sequence is not None and sequence != path.name:
            raise FlowvoError(f"is sequence {path.name}; sequence={sequence!r} names another", path)
        return {"data": str(path.parent.parent), "sequence": path.name}
    raise FlowvoError("is a folder but not in the KITTI layout (ROOT/sequences/NN/image_0, calib.txt, times.txt) nor "
                      "a ROS 2 bag", path)


class PushedFrames:
    """The frame source of frames handed in from Python (:class:`flowvo.api.odometry.Odometry`, or an iterable to
    :func:`flowvo.api.run`): a name, the frames' size, and no camera, ground truth or frame count of its own."""

    camera: InternalCamera | None = None
    camera_height_m: float | None = None
    camera_pitch_deg: float | None = None
    camera_roll_deg: float | None = None
    stamps_ns: np.ndarray | None = None
    is_synthetic = False

    def __init__(self, name: str, image_size_hw: tuple[int, int], frames: Iterator[tuple[float, np.ndarray]] = (),
                 frame_count: int | None = None, ground_truth: Trajectory | None = None) -> None:
        self.name = validate_name(name, "drive")
        self.image_size_hw = image_size_hw
        self.frame_count = frame_count
        self.ground_truth = ground_truth
        self._frames = frames

    def frames(self) -> Iterator[tuple[float, np.ndarray]]:
        """The frames, once."""
        yield from self._frames


def iterable_source(frames: Iterable[tuple[Any, Any]], name: str, channel_order: str,
                    ground_truth: Trajectory | None = None) -> PushedFrames:
    """A :class:`PushedFrames` over ``frames`` ((time_s, image) pairs, checked one by one as they stream); the
    first is read now for the frames' size."""
    checks = FrameChecks(channel_order)
    items = iter(frames)
    first = next(items, None)
    if first is None:
        raise FlowvoError("the frames are empty; odometry needs at least 2")

    def checked(item: Any) -> tuple[float, np.ndarray]:
        if not isinstance(item, tuple | list) or len(item) != 2:
            raise FlowvoError(f"item {checks.count} of the frames is not a (time_s, image) pair")
        return checks.check(item[1], item[0])

    head = checked(first)

    def stream() -> Iterator[tuple[float, np.ndarray]]:
        yield head
        for item in items:
            yield checked(item)

    count = len(frames) if hasattr(frames, "__len__") else None  # type: ignore[arg-type]
    return PushedFrames(name, head[1].shape, stream(), count, ground_truth)


def pushed_drive(options: RunOptions, source: PushedFrames) -> Drive:
    """The drive of frames handed in from Python: the camera of ``options`` checked against the frames' size (and
    a calibration file's size scaled to it), as ``flowvo run`` does for a video with ``--calib``."""
    from flowvo.camera_options import drive_camera, given_camera

    given = given_camera(options.calib, options.fx, options.fy, options.cx, options.cy, options.distortion,
                         options.distortion_model, options.camera_height_m, options.camera_pitch_deg,
                         options.camera_roll_deg, options.readout_ms)
    return Drive(source, drive_camera(given, None, source.image_size_hw, source.name))
