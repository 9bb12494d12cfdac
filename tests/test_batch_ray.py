"""``flowvo batch --ray``: a local Ray instance runs the drives as Ray tasks with the same outputs, summary
and failure isolation as local processes; without Ray, or with an address where no cluster answers, one
line and nothing written."""

import json
import sys
import time

import numpy as np
import pytest
from batch_fleet import make_fleet

from flowvo.cli import main


def summary(out):
    data = json.loads((out / "summary.json").read_text())
    return data["batch"], {row["drive"]: row for row in data["drives"]}


def test_a_batch_on_a_local_ray_instance_gives_what_local_workers_give(tmp_path):
    pytest.importorskip("ray")
    fleet = make_fleet(tmp_path)
    inputs = [str(fleet.kitti / "sequences" / "00"), str(fleet.good_video), str(fleet.broken_video)]
    common = ["-q", "batch", *inputs, "--calib", str(fleet.calib), "--method", "flowvo-geometry"]
    assert main([*common, "--out", str(tmp_path / "ray"), "--ray", "auto"]) == 1
    assert main([*common, "--out", str(tmp_path / "local"), "--workers", "2"]) == 1
    (ray_batch, ray_rows), (_, local_rows) = summary(tmp_path / "ray"), summary(tmp_path / "local")
    assert ray_batch["backend"] == "ray auto" and (ray_batch["ok"], ray_batch["failed"]) == (2, 1)
    keys = ("status", "error", "frames", "path_length_m", "kind", "output")
    assert {n: [r[k] for k in keys] for n, r in ray_rows.items()} == \
        {n: [r[k] for k in keys] for n, r in local_rows.items()}
    for row in ray_rows.values():
        if row["status"] == "ok":
            poses = next((tmp_path / "ray" / row["output"]).glob("*.txt"))
            local_poses = tmp_path / "local" / row["output"] / poses.name
            np.testing.assert_array_equal(np.loadtxt(poses), np.loadtxt(local_poses))
            assert row["peak_memory_mib"] > 0
    assert "OpenCV cannot open" in ray_rows["videos__broken.mp4"]["error"]


def test_without_ray_the_option_is_one_line_naming_the_extra(tmp_path, monkeypatch, capsys):
    (tmp_path / "a.mp4").write_bytes(b"")
    (tmp_path / "calib.txt").write_text("P0: 700 0 300 0 0 700 90 0 0 0 1 0\n")
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray fails, as where it is not installed
    code = main(["batch", str(tmp_path / "a.mp4"), "--calib", str(tmp_path / "calib.txt"), "--ray", "auto",
                 "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "pip install 'flowvo[ray]'" in err[0]
    assert not (tmp_path / "out").exists()


def test_an_address_where_no_cluster_answers_fails_fast_writing_nothing(tmp_path, capsys):
    pytest.importorskip("ray")
    (tmp_path / "a.mp4").write_bytes(b"")
    (tmp_path / "calib.txt").write_text("P0: 700 0 300 0 0 700 90 0 0 0 1 0\n")
    start = time.monotonic()
    code = main(["batch", str(tmp_path / "a.mp4"), "--calib", str(tmp_path / "calib.txt"), "--ray", "127.0.0.1:9",
                 "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "no Ray cluster answers at 127.0.0.1:9" in err[0]
    assert time.monotonic() - start < 10 and not (tmp_path / "out").exists()
