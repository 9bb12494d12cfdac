"""scripts/second_opinion_rotations.py end to end on real clip 06: the truth given as the run scores nothing against
the truth and the second opinion's own error against the second opinion, and a run of other frames is refused in one
line, as is a drive shorter than every sub-path."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "second_opinion_rotations.py"


def second_opinion(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_the_truth_as_the_run_scores_nothing_and_the_second_opinion_alike_both_ways(real_clips, tmp_path):
    done = second_opinion(str(real_clips), "06", str(real_clips / "poses" / "06.txt"), "--lengths", "10", "20", "30")
    assert done.returncode == 0, done.stderr
    rows = {line.split("|")[1].strip(): [float(cell) for cell in line.split("|")[2:4]]
            for line in done.stdout.splitlines() if line.startswith("| the ")}
    assert rows["the run against the truth"] == [0.0, 0.0]
    assert rows["the run against the second opinion"] == rows["the second opinion against the truth"]
    r_err, t_err = rows["the second opinion against the truth"]
    assert 0.0 < r_err < 0.03 and 0.0 < t_err < 2.0  # real frames, 10-30 m sub-paths
    assert "their correlation" in done.stdout


def test_a_run_of_other_frames_is_refused_in_one_line(real_clips, tmp_path):
    truth = np.loadtxt(real_clips / "poses" / "06.txt")
    np.savetxt(tmp_path / "short.txt", truth[:-1])
    done = second_opinion(str(real_clips), "06", str(tmp_path / "short.txt"))
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "short.txt" in done.stderr and "50 frames" in done.stderr


def test_a_drive_shorter_than_every_sub_path_is_refused_before_the_work(real_clips):
    done = second_opinion(str(real_clips), "06", str(real_clips / "poses" / "06.txt"))  # 59 m, the devkit's 100..800
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "06.txt" in done.stderr and "give shorter --lengths" in done.stderr
