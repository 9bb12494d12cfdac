"""A live view of odometry in Rerun (the ``rerun`` extra: ``pip install 'flowvo[rerun]'``): ``flowvo run --rerun``
(``--rerun-save run.rrd``), ``flowvo.Odometry(..., rerun=...)`` and ``flowvo.run(..., rerun=...)``.

What it shows, on the timelines ``frame`` (0-based) and ``time`` (the frames' seconds):

- ``world``: the first frame's camera frame (x right, y down, z forward; metres); ``world/camera``: each final
  pose as a ``Transform3D`` (camera to world), with its KITTI row-major ``[R | t]`` (12 float64) as
  ``kitti_pose``; ``world/trajectory``: the path so far (at most :data:`PATH_POINTS` points, evenly thinned);
- ``world/camera/image``: the method's working frame (JPEG) under its pinhole (working pixels); for the default
  method its tracked points (``tracks/inliers``, ``tracks/outliers`` of the step's essential fit), the road crop
  (``road/crop``: green when the step's road plane was trusted) and the road's flow (``road/flow``: arrows from
  where each road point was in the road key frame to where it is); ``world/camera/road_plane``: the trusted road
  plane as a quad 5-30 m ahead, 4 m either side, at the camera height below (metres, camera frame);
- ``series/speed_mps``, ``series/length_log_sigma`` and ``series/measured_by/{road,ratio,network}`` (1 where that
  measured the step) for each final step; ``series/tracks/{inliers,outliers}`` per frame; ``log/steps``: one line
  per step.

Poses come ``latency_frames`` frames after their frame's image: Rerun files each under its own frame.
A saved ``.rrd`` is written under a temporary name beside the target and renamed into place when the view closes
successfully (removed otherwise), as every other flowvo output.
"""

from __future__ import annotations

import os
import tempfile
import threading
from pathlib import Path
from typing import Any

import numpy as np

from flowvo.api.pose import StepRecords
from flowvo.errors import FlowvoError
from flowvo.io.outputs import prepare_output_file
from flowvo.optional import import_optional

PATH_POINTS = 1000  # the path drawn holds at most this many points (a long drive's is thinned evenly)
ROAD_QUAD_M = ((-4.0, 5.0), (4.0, 5.0), (4.0, 30.0), (-4.0, 30.0))  # (x, z) corners of the road plane drawn, metres
MEASURED_BY = ("road", "ratio", "network")
INLIER_RGB, OUTLIER_RGB = (40, 220, 90), (235, 60, 50)
JPEG_QUALITY = 85
FLUSH_TIMEOUT_S = 10.0  # at the end of a drive, the most a viewer that stopped answering may hold it up


def _rerun() -> Any:
    return import_optional("rerun", "the live view (--rerun)", "rerun")


def blueprint() -> Any:
    """The layout: the 3-D path and camera beside the frame and the time series."""
    import rerun.blueprint as rrb

    return rrb.Blueprint(rrb.Horizontal(
        rrb.Spatial3DView(origin="world", name="trajectory"),
        rrb.Vertical(rrb.Spatial2DView(origin="world/camera/image", name="frame"),
                     rrb.TimeSeriesView(origin="series", name="steps"))))


class RerunLogger:
    """Logs an odometry run to Rerun: ``spawn`` the viewer, ``save`` an ``.rrd`` file (an earlier file is replaced only
    with ``force``; never inside ``dataset``), or log into the caller's ``recording`` (a ``rerun.RecordingStream``).
    Nothing is opened before the first frame. Use it as a context manager, or call :meth:`close`."""

    def __init__(self, *, spawn: bool = False, save: str | Path | None = None, recording: Any = None,
                 force: bool = False, dataset: str | Path | None = None, application_id: str = "flowvo") -> None:
        self.rr = _rerun()
        if not (spawn or save is not None or recording is not None):
            raise FlowvoError("a Rerun view needs spawn=True, save=PATH or recording=")
        self.spawn = spawn
        self.target = None if save is None else prepare_output_file(save, force, "--rerun-save", dataset)
        self.recording = recording
        self.application_id = application_id
        self._temporary: Path | None = None
        self._opened = self._closed = False
        self._lock = threading.Lock()
        self._records: StepRecords | None = None
        self._pinhole_of: tuple | None = None
        self._path_m: list[np.ndarray] = []
        self._last: tuple[float, np.ndarray] | None = None

    def __enter__(self) -> RerunLogger:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None, traceback: Any) -> None:
        self.close(ok=kind is None)

    def _open(self) -> Any:
        """The recording, its sinks set up at the first call."""
        if self._closed:
            raise FlowvoError("this Rerun view is closed")
        if self._opened:
            return self.recording
        rr = self.rr
        own = self.recording is None
        if own:
            self.recording = rr.RecordingStream(self.application_id)
        if self.target is not None:
            handle, name = tempfile.mkstemp(prefix=f".{self.target.stem}.", suffix=".rrd", dir=self.target.parent)
            os.close(handle)
            self._temporary = Path(name)
        if self.spawn:
            try:
                self.recording.spawn(connect=False)
            except (RuntimeError, OSError) as error:
                raise FlowvoError(f"cannot start the Rerun viewer ({error}); without a display, record with "
                                  "--rerun-save FILE.rrd (rerun=PATH) and open the file where there is one") from None
            sinks = [rr.GrpcSink()] + ([] if self._temporary is None else [rr.FileSink(str(self._temporary))])
            self.recording.set_sinks(*sinks, default_blueprint=blueprint())
        elif self._temporary is not None:
            self.recording.save(self._temporary, default_blueprint=blueprint())
        self.recording.log("world", rr.ViewCoordinates.RDF, static=True)
        self._opened = True
        return self.recording

    def close(self, ok: bool = True) -> Path | None:
        """Finish the view: flush, and put the ``.rrd`` file in place (``ok``) or remove it. Returns the file's path."""
        with self._lock:
            if self._closed:
                return self.target if ok else None
            if ok and not self._opened:
                self._open()  # an empty drive still gives its file
            self._closed = True
            if self._opened:
                try:
                    self.recording.flush(timeout_sec=FLUSH_TIMEOUT_S)
                except RuntimeError:  # the viewer is gone (closed by its user, or never started): the file still
                    pass  # gets every row, on disconnect
                if self.target is not None or self.spawn:
                    self.recording.disconnect()
            if self._temporary is None:
                return None
            if ok:
                os.chmod(self._temporary, 0o644)
                os.replace(self._temporary, self.target)
                return self.target
            self._temporary.unlink(missing_ok=True)
            return None

    def _at(self, index: int, time_s: float) -> Any:
        recording = self._open()
        recording.set_time("frame", sequence=index)
        recording.set_time("time", duration=time_s)
        return recording

    def frame(self, index: int, time_s: float, prepared: Any, motion: np.ndarray | None, step: Any) -> None:
        """Frame ``index`` after its step's motion: the working frame, and the default method's tracks and road."""
        rr = self.rr
        with self._lock:
            recording = self._at(index, time_s)
            image = getattr(prepared, "image", prepared)
            if isinstance(image, np.ndarray) and image.ndim == 2:
                K = np.asarray(getattr(step, "K", None) if getattr(step, "K", None) is not None else step.camera.K)
                pinhole = (image.shape, tuple(K.ravel()))
                if pinhole != self._pinhole_of:
                    recording.log("world/camera/image", rr.Pinhole(image_from_camera=K, width=image.shape[1],
                                                                   height=image.shape[0]), static=True)
                    self._pinhole_of = pinhole
                recording.log("world/camera/image", rr.Image(image).compress(jpeg_quality=JPEG_QUALITY))
            view = getattr(step, "last_view", None)
            if view is not None and view[0] == time_s:
                self._method_view(recording, step, *view[1:])

    def _method_view(self, recording: Any, step: Any, flow: Any, fit: Any, plane: Any) -> None:
        """The default method's tracked points, road crop, road flow and trusted road plane."""
        from flowvo.camera import distort_points

        rr = self.rr
        tracked = np.asarray(flow.current.tracked_next, dtype=np.float64)  # frame pixels (distorted)
        inliers = np.zeros(len(tracked), bool) if fit is None or len(fit.inliers) != len(tracked) else \
            np.asarray(fit.inliers, bool)
        recording.log("world/camera/image/tracks/inliers", rr.Points2D(tracked[inliers], colors=INLIER_RGB, radii=1.5))
        recording.log("world/camera/image/tracks/outliers", rr.Points2D(tracked[~inliers], colors=OUTLIER_RGB,
                                                                        radii=1.5))
        recording.log("series/tracks/inliers", rr.Scalars(float(inliers.sum())))
        recording.log("series/tracks/outliers", rr.Scalars(float((~inliers).sum())))
        rows, columns = step.road.crop
        recording.log("world/camera/image/road/crop", rr.Boxes2D(
            mins=[columns.start, rows.start], sizes=[columns.stop - columns.start, rows.stop - rows.start],
            colors=INLIER_RGB if plane is not None else (160, 160, 160)))
        if len(flow.road_next):
            start = distort_points(flow.road_prev[::3], step.K, step.camera.distortion)
            end = distort_points(flow.road_next[::3], step.K, step.camera.distortion)
            recording.log("world/camera/image/road/flow", rr.Arrows2D(origins=start, vectors=end - start,
                                                                      colors=(90, 160, 255)))
        if plane is None:
            recording.log("world/camera/road_plane", rr.Clear(recursive=False))
            return
        normal, height_m = np.asarray(plane.normal, dtype=np.float64), step.camera.camera_height_m
        corners = np.array([[x, (height_m - normal[0] * x - normal[2] * z) / normal[1], z] for x, z in ROAD_QUAD_M])
        recording.log("world/camera/road_plane", rr.Mesh3D(vertex_positions=corners,
                                                           triangle_indices=[[0, 1, 2], [0, 2, 3]],
                                                           albedo_factor=(40, 220, 90, 90)))

    def pose(self, index: int, time_s: float, T_world_cam: np.ndarray, step: Any) -> None:
        """Final pose ``index``: the camera's transform, the path so far and the step's series."""
        rr = self.rr
        with self._lock:
            recording = self._at(index, time_s)
            T = np.asarray(T_world_cam, dtype=np.float64)
            recording.log("world/camera", rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]),
                          rr.AnyValues(kitti_pose=T[:3, :4].reshape(-1)))
            self._path_m.append(T[:3, 3].copy())
            path = self._path_m if len(self._path_m) <= PATH_POINTS else \
                [self._path_m[int(i)] for i in np.linspace(0, len(self._path_m) - 1, PATH_POINTS)]
            recording.log("world/trajectory", rr.LineStrips3D([np.array(path)], colors=(255, 170, 0)))
            if self._last is not None and time_s > self._last[0]:
                length_m = float(np.linalg.norm(T[:3, 3] - self._last[1]))
                recording.log("series/speed_mps", rr.Scalars(length_m / (time_s - self._last[0])))
                self._step_series(recording, index, time_s, length_m, step)
            self._last = time_s, T[:3, 3].copy()

    def _step_series(self, recording: Any, index: int, time_s: float, length_m: float, step: Any) -> None:
        """What measured the step ending at ``time_s``, and the sigma of its log length (windowed methods)."""
        rr = self.rr
        if self._records is None or self._records.step is not step:
            self._records = StepRecords(step)
        record = self._records.of(time_s)
        if record is None:
            return
        if record.log_sigma is not None:
            recording.log("series/length_log_sigma", rr.Scalars(record.log_sigma))
        kinds = record.measured_by.split("+")
        for kind in MEASURED_BY:
            recording.log(f"series/measured_by/{kind}", rr.Scalars(float(kind in kinds)))
        sigma = "" if record.log_sigma is None else f" +- {100 * record.log_sigma:.1f} %"
        recording.log("log/steps", rr.TextLog(f"frame {index}: {length_m:.3f} m{sigma}, measured by "
                                              f"{record.measured_by}"))
