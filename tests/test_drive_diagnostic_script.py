"""scripts/drive_diagnostic.py end to end: the tables it prints for a run with a known rotation bias, and its one-line
error for a run of other frames."""

import subprocess
import sys
from pathlib import Path

import numpy as np

from flowvo.geometry import chain_planar, chain_se3, relative_motions, so3_exp

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "drive_diagnostic.py"


def diagnose(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=120)


def test_a_run_pitched_up_every_step_reads_its_bias_and_scores_nothing_once_it_is_removed(tmp_path):
    truth = chain_planar(np.c_[np.full(150, 0.8), 0.01 * np.sin(np.arange(150) / 15.0)])  # 120 m of gentle bends
    steps = relative_motions(truth)
    steps[:, :3, :3] = steps[:, :3, :3] @ so3_exp([np.radians(0.003), 0.0, 0.0])
    np.savetxt(tmp_path / "gt.txt", truth[:, :3].reshape(-1, 12))
    np.savetxt(tmp_path / "run.txt", chain_se3(steps)[:, :3].reshape(-1, 12), fmt="%.15e")
    done = diagnose(str(tmp_path / "gt.txt"), str(tmp_path / "run.txt"), "--lengths", "20", "50")
    assert done.returncode == 0, done.stderr
    assert "| the run, its mean rotation error per step removed | 0.00 | 0.0000 |" in done.stdout
    assert "pitch +3.00 (positive nose up), yaw +0.00 (positive right), roll +0.00" in done.stdout
    assert "turns read short): 1.0000." in done.stdout
    assert "| the run | 0.11 | 0.0038 |" in done.stdout  # a pitch is no turn gain: rescaling the yaw leaves it
    assert "| the run, its yaw per step over its yaw slope (turns at their true size) | 0.11 | 0.0038 |" in done.stdout
    assert "| 6-9 | 112 | 49.0 | 1.0000 |" in done.stdout  # 8 m/s, every turn read at its size
    assert "**Per 50 frames**" in done.stdout and "**Per 100 m**" in done.stdout


def test_a_run_of_other_frames_is_refused_in_one_line(tmp_path):
    truth = chain_planar(np.c_[np.full(30, 1.0), np.zeros(30)])
    np.savetxt(tmp_path / "gt.txt", truth[:, :3].reshape(-1, 12))
    np.savetxt(tmp_path / "run.txt", truth[:-1, :3].reshape(-1, 12))
    done = diagnose(str(tmp_path / "gt.txt"), str(tmp_path / "run.txt"))
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "run.txt" in done.stderr and "every one of 31 frames" in done.stderr
