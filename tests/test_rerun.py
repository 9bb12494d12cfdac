"""The live view in Rerun (flowvo.api.rerun): an .rrd recorded by ``flowvo run --rerun-save`` or the API holds one
camera pose per frame, equal to the KITTI file, and the frame, tracks, road and series; it is written whole or not
at all, and never over an earlier file without --force."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import cv2
import numpy as np
import pytest

import flowvo
from flowvo.cli import main
from flowvo.errors import FlowvoError

pytest.importorskip("rerun", reason="the live view needs the rerun extra (pip install 'flowvo[rerun]')")
from rerun.chunk import RrdReader  # noqa: E402

from flowvo.api.rerun import RerunLogger  # noqa: E402


@pytest.fixture(scope="session")
def clip(clip_06: Path) -> Path:
    """Real clip 06 (conftest)."""
    return clip_06


def read_rrd(path: Path) -> dict[str, dict[str, list]]:
    """Entity path -> column name -> values, rows in frame order (static rows left out)."""
    columns: dict[str, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    rows: dict[str, list] = defaultdict(list)
    for chunk in RrdReader(path).stream():
        if chunk.is_static:
            continue
        table = chunk.to_record_batch()
        names = [name for name in table.schema.names if name not in ("rerun.controls.RowId", "log_time", "time")]
        rows[chunk.entity_path] += zip(*(table.column(name).to_pylist() for name in names), strict=True)
        columns[chunk.entity_path]["names"] = names
    for entity, values in rows.items():
        names = columns[entity].pop("names")
        for row in sorted(values, key=lambda row: row[names.index("frame")]):
            for name, value in zip(names, row, strict=True):
                columns[entity][name].append(value)
    return columns


@pytest.fixture(scope="module")
def recorded(clip, tmp_path_factory) -> tuple[Path, dict]:
    out = tmp_path_factory.mktemp("rerun")
    assert main(["-q", "run", "--data", str(clip.parents[1]), "--sequence", "06", "--out", str(out / "run"),
                 "--rerun-save", str(out / "06.rrd")]) == 0
    return out, read_rrd(out / "06.rrd")


def test_rerun_save_records_one_camera_pose_per_frame_equal_to_the_kitti_file(recorded):
    out, entities = recorded
    camera = entities["/world/camera"]
    assert camera["frame"] == list(range(50))
    lines = (out / "run" / "06.txt").read_text().splitlines()
    assert [" ".join(f"{value:.9e}" for value in pose) for pose in camera["kitti_pose"]] == lines
    kitti = np.array([[float(value) for value in line.split()] for line in lines]).reshape(-1, 3, 4)
    translations = np.array([row[0] for row in camera["Transform3D:translation"]])
    rotations = np.array([np.reshape(row[0], (3, 3)).T for row in camera["Transform3D:mat3x3"]])  # column-major
    np.testing.assert_allclose(translations, kitti[:, :, 3], rtol=1e-6, atol=1e-6)  # float32 in the Transform3D
    np.testing.assert_allclose(rotations, kitti[:, :, :3], atol=1e-6)


def test_rrd_holds_the_frame_tracks_road_plane_path_and_series(recorded):
    _, entities = recorded
    assert entities["/world/camera/image"]["frame"] == list(range(50))
    inliers = entities["/world/camera/image/tracks/inliers"]
    outliers = entities["/world/camera/image/tracks/outliers"]
    assert inliers["frame"] == list(range(1, 50))  # one set of tracks per step
    counts = [len(points) for points in inliers["Points2D:positions"]]
    assert min(counts) > 100 and all(len(points) > 0 for points in outliers["Points2D:positions"])
    assert entities["/series/tracks/inliers"]["Scalars:scalars"] == [[float(count)] for count in counts]
    assert len(entities["/world/camera/image/road/crop"]["frame"]) == 49
    planes = entities["/world/camera/road_plane"]
    assert sum(bool(row) for row in planes["Mesh3D:vertex_positions"]) >= 45  # clip 06: the road trusted nearly always
    path = entities["/world/trajectory"]["LineStrips3D:strips"]
    assert [len(strips[0]) for strips in path] == list(range(1, 51))  # the path grows by one pose a frame
    speeds = [row[0] for row in entities["/series/speed_mps"]["Scalars:scalars"]]
    assert len(speeds) == 49 and 10 < np.median(speeds) < 13  # clip 06: 59 m in 4.9 s
    road = [row[0] for row in entities["/series/measured_by/road"]["Scalars:scalars"]]
    assert len(road) == 49 and sum(road) == 49  # steps_csv: road+ratio 48, road 1
    assert len(entities["/log/steps"]["TextLog:text"]) == 49


def test_pushed_frames_with_rerun_record_the_poses_pushed(clip, tmp_path):
    times_s = np.loadtxt(clip / "times.txt")[:12]
    vo = flowvo.Odometry(flowvo.Camera.from_file(clip / "calib.txt"), rerun=tmp_path / "pushed.rrd")
    for index, time_s in enumerate(times_s):
        vo.push(cv2.imread(str(clip / "image_0" / f"{index:06d}.png"), cv2.IMREAD_GRAYSCALE), time_s)
        assert not (tmp_path / "pushed.rrd").exists()  # written whole when the drive ends
    vo.close()
    camera = read_rrd(tmp_path / "pushed.rrd")["/world/camera"]
    expected = [pose.T_world_cam[:3, :4].reshape(-1).tolist() for pose in vo.poses]
    assert camera["frame"] == list(range(12)) and camera["kitti_pose"] == expected


def test_rerun_save_refuses_an_earlier_file_without_force(clip, tmp_path, capsys):
    (tmp_path / "old.rrd").write_text("earlier")
    code = main(["run", "--data", str(clip.parents[1]), "--sequence", "06", "--out", str(tmp_path / "run"),
                 "--max-frames", "3", "--method", "classical", "--rerun-save", str(tmp_path / "old.rrd")])
    assert code == 2 and "holds an earlier result" in capsys.readouterr().err
    assert (tmp_path / "old.rrd").read_text() == "earlier" and not (tmp_path / "run").exists()


def test_a_failed_drive_leaves_no_rrd(tmp_path):
    with pytest.raises(FlowvoError, match="timestamps must increase"):
        flowvo.run([(0.0, np.zeros((120, 160), np.uint8)), (0.0, np.zeros((120, 160), np.uint8))],
                   camera=flowvo.Camera(150, 150, 80, 60), method="classical", rerun=tmp_path / "failed.rrd")
    assert list(tmp_path.iterdir()) == []


def test_a_logger_into_the_callers_recording_opens_nothing_of_its_own(clip, tmp_path):
    import rerun as rr

    recording = rr.RecordingStream("mine")
    recording.save(tmp_path / "mine.rrd")
    with RerunLogger(recording=recording) as view:
        flowvo.run(clip, method="classical", max_frames=4, rerun=view)
    recording.flush()
    recording.disconnect()
    assert read_rrd(tmp_path / "mine.rrd")["/world/camera"]["frame"] == [0, 1, 2, 3]


def test_without_the_rerun_package_the_flag_is_one_line_naming_the_extra(clip, tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(__import__("sys").modules, "rerun", None)
    code = main(["run", "--data", str(clip.parents[1]), "--sequence", "06", "--out", str(tmp_path / "run"),
                 "--rerun"])
    err = capsys.readouterr().err
    assert code == 2 and "pip install 'flowvo[rerun]'" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "run").exists()
