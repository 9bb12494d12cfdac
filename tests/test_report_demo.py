import json
import re

import pytest

from flowvo.cli import main
from flowvo.model.checkpoint import packaged_model_path
from flowvo.synth.dataset import synthesize


@pytest.fixture(scope="module")
def classical_runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("reportdata")
    synthesize(root, ["00"], seed=8, frames=220, scale=0.5, workers=2)
    runs = []
    for source in ("gt", "height"):
        out = tmp_path_factory.mktemp("reportruns") / f"run_{source}"  # results never go into the dataset
        assert main(["run", "--data", str(root), "--sequence", "00", "--method", "classical",
                     "--scale-from", source, "--out", str(out), "-q"]) == 0
        runs.append(out)
    return root, runs


def test_report_numbers_equal_flowvo_eval(classical_runs, tmp_path, capsys):
    root, runs = classical_runs
    assert main(["report", *map(str, runs), "--out", str(tmp_path / "report")]) == 0
    page = (tmp_path / "report" / "index.html").read_text()
    records = json.loads(re.search(r"<script type='application/json' id='results'>(.*?)</script>", page).group(1))
    for record, run in zip(records, runs, strict=True):
        assert main(["eval", "--gt", str(root / "poses" / "00.txt"), "--pred", str(run / "00.txt"),
                     "--out", str(tmp_path / run.name)]) == 0
        metrics = json.loads((tmp_path / run.name / "metrics.json").read_text())
        assert record["t_err_percent"] == metrics["t_err_percent"]
        assert record["r_err_deg_per_m"] == metrics["r_err_deg_per_m"]
        assert f"{metrics['t_err_percent']:.2f}" in page


def test_report_has_every_section(classical_runs, tmp_path):
    _, runs = classical_runs
    main(["report", *map(str, runs), "--out", str(tmp_path)])
    page = (tmp_path / "index.html").read_text()
    for text in ("Synthetic data", "reference system (2016), published", "frame-weighted average", "10.77",
                 "0.0623", "speed-up vs reference", "speed-up vs baseline", "Timing on this machine",
                 "What each drive did", "<th>top speed, 1 s [m/s]</th>"):
        assert text in page
    for png in ("path_00.png", "t_err_vs_length_00.png", "r_err_vs_speed_00.png", "frame_errors_00.png"):
        assert f"src='{png}'" in page and (tmp_path / png).is_file()


def test_classical_baseline_with_gt_scale_tracks_the_synthetic_drive(classical_runs):
    _, runs = classical_runs
    summary = json.loads((runs[0] / "run.json").read_text())
    assert summary["synthetic"] is True
    assert summary["metrics"]["t_err_percent"] < 10.0  # measured ~2 % on such drives
    timing = json.loads((runs[0] / "timing.json").read_text())
    assert set(timing["seconds_per_frame"]) == {"image_read", "flow", "network", "geometry", "window", "chaining",
                                               "total"}


def test_bench_prints_the_timing_table(classical_runs, capsys):
    root, _ = classical_runs
    assert main(["bench", "--data", str(root), "--sequence", "00", "--frames", "12", "--repeat", "2"]) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[2].startswith("flowvo (") and "0.633" in table[5]  # the default method first, then the reference
    decoding = table[-1]  # one core decoding the same frames before each run, each method's rate over it
    assert decoding.startswith("decoding alone on one core before each run: ") and "run by run: flowvo 0." in decoding
    assert table[3].startswith("cnn (") and table[4].startswith("classical (")
    stage_cells = {row.split()[0]: row[63:].split()[:5] for row in table[2:5]}  # read flow network geometry chain
    assert stage_cells["flowvo"][2] == "-" and stage_cells["cnn"][3] == "-"  # no network / no geometry stage
    assert stage_cells["classical"][2] == "-" and stage_cells["classical"][3] != "-"  # KLT, then the geometry


def test_report_refuses_a_folder_that_is_not_a_run(tmp_path, capsys):
    assert main(["report", str(tmp_path), "--out", str(tmp_path / "r")]) == 2
    assert "not a flowvo run folder (no run.json)" in capsys.readouterr().err


@pytest.mark.slow
def test_demo_runs_end_to_end_with_the_packaged_model(tmp_path, capsys):
    assert packaged_model_path().stat().st_size < 8_000_000
    assert main(["demo", "--frames", "160", "--out", str(tmp_path), "-q"]) == 0
    printed = capsys.readouterr().out
    assert "report:" in printed and "synthetic" in printed
    page = (tmp_path / "report" / "index.html").read_text()
    assert "flowvo (dis-road road flow, geometry, network fallback, 5-frame scale window)" in page
    assert "cnn (dis-medium flow + network)" in page
    assert "classical (KLT" in page
    assert re.search(r"flowvo \(dis-road[^\n]*(t_err|ATE) +\d+\.\d\d[^\n]*frames/s", printed)  # summary
    seconds = r"\d+\.\d{4}"

    def network_cell(method: str) -> str:  # the timing table's network column for the method's row
        found = re.search(rf"<tr><td>{method}[^<]*</td><td>\d+</td>(?:<td>{seconds}</td>){{2}}<td>([^<]*)</td>", page)
        return found.group(1) if found else "row not found"

    assert re.fullmatch(seconds, network_cell("cnn"))
    assert network_cell("flowvo") == "-" and network_cell("classical") == "-"  # they have no network stage
