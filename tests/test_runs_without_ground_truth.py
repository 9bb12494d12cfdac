"""Runs without ground truth are first-class: ``flowvo run`` prints and records what the drive did (distance,
duration, mean and top speed, heading change) and ``flowvo report`` shows it per run, draws every run's
path, and shows no error tables, reference figures or n/a cells where nothing can be scored. The drive: a
video of real KITTI frames (clip 06, 20 frames) with its calib.txt given, so nothing knows its ground truth."""

import json
import re
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from flowvo.cli import main
from flowvo.report import page, plots
from flowvo.report.drive_summary import drive_summary

CLIPS = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real" / "kitti_clips"
FRAMES = 20
DRIVE_KEYS = {"distance_m", "duration_s", "mean_speed_mps", "top_speed_mps", "heading_change_deg"}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The video and two runs of it at two camera heights (1.65 m assumed, 1.3 m given)."""
    if not CLIPS.is_dir():
        pytest.skip(f"shared KITTI clips not found at {CLIPS}")
    root = tmp_path_factory.mktemp("no_ground_truth")
    frames = [cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
              for path in sorted((CLIPS / "sequences" / "06" / "image_0").glob("*.png"))[:FRAMES]]
    h, w = frames[0].shape
    video = root / "clip 06.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"FFV1"), 10.0, (w, h))  # lossless, 10 frames/s
    for frame in frames:
        writer.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR))
    writer.release()
    outs = {}
    for name, height in (("assumed", []), ("low", ["--camera-height", "1.3"])):
        out = root / name
        code = main(["-q", "run", "--video", str(video), "--calib", str(CLIPS / "sequences" / "06" / "calib.txt"),
                     *height, "--out", str(out)])
        assert code == 0
        outs[name] = out
    return root, outs


def recorded_drive(out: Path) -> dict:
    return json.loads((out / "run.json").read_text())["drive"]


def test_run_records_the_drive_computed_from_its_own_poses_and_times(runs):
    _, outs = runs
    drive = recorded_drive(outs["assumed"])
    assert set(drive) == DRIVE_KEYS
    poses = np.loadtxt(outs["assumed"] / "clip_06.txt").reshape(-1, 3, 4)
    T = np.tile(np.eye(4), (len(poses), 1, 1))
    T[:, :3] = poses
    times = np.loadtxt(outs["assumed"] / "clip_06.tum")[:, 0]
    assert drive == pytest.approx(drive_summary(T, times), rel=1e-6)  # the files hold what run.json says
    assert drive["duration_s"] == pytest.approx((FRAMES - 1) / 10)
    truth = np.loadtxt(CLIPS / "poses" / "06.txt")[:FRAMES].reshape(-1, 3, 4)[:, :, 3]
    assert drive["distance_m"] == pytest.approx(np.linalg.norm(np.diff(truth, axis=0), axis=1).sum(), rel=0.1)
    assert drive["top_speed_mps"] >= drive["mean_speed_mps"] and abs(drive["heading_change_deg"]) < 2  # straight


def test_run_prints_the_drive_in_one_line(runs, tmp_path, capsys):
    root, outs = runs
    out = tmp_path / "again"
    assert main(["-q", "run", "--video", str(root / "clip 06.avi"), "--calib",
                 str(CLIPS / "sequences" / "06" / "calib.txt"), "--out", str(out)]) == 0
    d = recorded_drive(out)
    line = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("drive:"))
    assert line == (f"drive: {d['distance_m']:.1f} m in 1.9 s, mean speed {d['mean_speed_mps']:.1f} m/s "
                    f"({3.6 * d['mean_speed_mps']:.0f} km/h), top {d['top_speed_mps']:.1f} m/s "
                    f"({3.6 * d['top_speed_mps']:.0f} km/h, over 1 s), heading change "
                    f"{d['heading_change_deg']:+.1f} deg (left +)")


def test_report_shows_each_runs_drive_and_every_path_and_nothing_it_cannot_score(runs, tmp_path, monkeypatch):
    _, outs = runs
    drawn = []

    def plot_paths(paths, gt_positions, title, path):
        drawn.append((dict(paths), gt_positions))
        return real_plot_paths(paths, gt_positions, title, path)

    real_plot_paths = plots.plot_paths
    monkeypatch.setattr(plots, "plot_paths", plot_paths)
    report = tmp_path / "report"
    assert main(["report", str(outs["assumed"]), str(outs["low"]), "--out", str(report)]) == 0
    html = (report / "index.html").read_text()
    visible = html[:html.index("<script")]  # the page, not its JSON (whose runs hold null metrics)
    for text in ("reference system", "2016", "n/a", "t_err", "ATE", "speed-up vs"):
        assert text not in visible
    assert "No run has ground truth" in html
    for name, height in (("assumed", "1.65 (assumed)"), ("low", "1.3")):
        d = recorded_drive(outs[name])
        row = (f"<td>{outs[name]}</td><td>flowvo (dis-road road flow, geometry, network fallback, 5-frame scale "
               f"window)</td><td>clip_06 (video)</td><td>calib, fx 707.1 px</td><td>{height}</td><td>{FRAMES}</td>"
               f"<td>{d['distance_m']:.1f}</td><td>1.9</td><td>{d['mean_speed_mps']:.1f}</td>"
               f"<td>{d['top_speed_mps']:.1f}</td><td>{d['heading_change_deg']:+.1f}</td></tr>")
        assert row in html
    records = json.loads(re.search(r"<script type='application/json' id='results'>(.*?)</script>", html).group(1))
    assert [r["run_folder"] for r in records] == [str(outs["assumed"]), str(outs["low"])]
    assert [r["camera_height_m"] for r in records] == [1.65, 1.3] and not any(r["ground_truth"] for r in records)
    for record, name in zip(records, ("assumed", "low"), strict=True):
        assert record["drive"] == pytest.approx(recorded_drive(outs[name]), rel=1e-6)  # from the pose files
    (paths, gt), = drawn  # one drive, both runs on it, no ground truth
    assert gt is None and len(paths) == 2 and all(name.endswith(("(assumed)", "(low)")) for name in paths)
    lengths = sorted(np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p in paths.values())
    assert lengths[0] / lengths[1] == pytest.approx(1.3 / 1.65, rel=0.01)  # the two runs, not one drawn twice
    assert (report / "path_clip_06.png").is_file()


def test_report_scores_only_the_runs_with_ground_truth(runs, tmp_path):
    _, outs = runs
    kitti = tmp_path / "kitti"
    assert main(["-q", "run", "--data", str(CLIPS), "--sequence", "06", "--max-frames", str(FRAMES),
                 "--out", str(kitti)]) == 0
    report = tmp_path / "report"
    assert main(["report", str(outs["assumed"]), str(kitti), "--out", str(report)]) == 0
    html = (report / "index.html").read_text()
    html = html[:html.index("<script")]  # the page, not its JSON
    errors = html[html.index("<h2>Errors against ground truth (ATE; no path is long enough for the KITTI metric's "
                             "100..800 m sub-paths)</h2>"):html.index("<h2>Timing")]
    assert errors.count("<tr>") == 2 and "06 (KITTI)" in errors and "clip_06" not in errors  # header + the KITTI run
    assert "n/a" not in html and "t_err" not in html  # 20 frames: no 100 m sub-path, no KITTI metric columns
    assert "reference system (2016), published (GPU)" in html  # a run with ground truth: its rate beside ours
    drives = html[html.index("<h2>What each drive did"):html.index("<h2>Errors")]
    assert drives.count("<tr><td>") == 2  # both runs in the drive table
    assert (report / "frame_errors_06.png").is_file() and not (report / "t_err_vs_length_06.png").exists()


def test_report_reads_the_recorded_drive_of_a_run_without_a_tum_file(runs, tmp_path):
    _, outs = runs
    old = tmp_path / "old"
    shutil.copytree(outs["assumed"], old)
    (old / "clip_06.tum").unlink()
    assert page.load_run(old).drive == pytest.approx(recorded_drive(outs["assumed"]))


TUM_DAMAGE = {
    "cut short": (lambda lines: lines[:10], "clip_06.tum: holds 10 timestamps for the pose file's 20 poses"),
    "a word for a time": (lambda lines: ["soon" + lines[0][lines[0].index(" "):], *lines[1:]],
                          "clip_06.tum:1: timestamp 'soon' is not a number"),
    "a time repeated": (lambda lines: [lines[0], lines[0], *lines[2:]],
                        "clip_06.tum:2: timestamp 0.000000000 must be finite and later than the line before's"),
    "a field missing": (lambda lines: [lines[0].rsplit(" ", 1)[0], *lines[1:]],
                        "clip_06.tum:1: expected 8 numbers (t tx ty tz qx qy qz qw), found 7 fields"),
}


@pytest.mark.parametrize("damage", TUM_DAMAGE)
def test_report_refuses_a_damaged_tum_file_in_one_line_naming_it(runs, tmp_path, capsys, damage):
    _, outs = runs
    spoil, message = TUM_DAMAGE[damage]
    damaged = tmp_path / "damaged"
    shutil.copytree(outs["assumed"], damaged)
    lines = (damaged / "clip_06.tum").read_text().splitlines()
    (damaged / "clip_06.tum").write_text("\n".join(spoil(lines)) + "\n")
    assert main(["report", str(damaged), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.strip().endswith(message)
    assert not (tmp_path / "r").exists()
