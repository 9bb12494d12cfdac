"""The light sub-commands start fast: --help and eval never import torch (1-2 s and ~300 MB)."""

import subprocess
import sys

import numpy as np
import pytest

from flowvo.geometry import chain_planar
from flowvo.kitti.poses import write_kitti_poses
from flowvo.trajectory import Trajectory

RUN_WITHOUT_TORCH = """
import sys
from flowvo.cli import main
try:
    code = main(sys.argv[1:])
except SystemExit as exit:
    code = exit.code
assert "torch" not in sys.modules, "torch was imported"
sys.exit(code)
"""


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", RUN_WITHOUT_TORCH, *args], capture_output=True, text=True)


@pytest.mark.parametrize("args", [["--help"], ["eval", "--help"], ["flow", "--help"], ["export", "--help"]])
def test_help_does_not_import_torch(args):
    result = run_cli(*args)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage: flowvo")


def test_eval_with_plots_does_not_import_torch(tmp_path):
    steps = np.column_stack([np.full(50, 1.0), np.full(50, 0.01)])
    write_kitti_poses(tmp_path / "gt.txt", Trajectory.from_poses(chain_planar(steps)))
    write_kitti_poses(tmp_path / "pred.txt", Trajectory.from_poses(chain_planar(steps * [1.02, 1.0])))
    result = run_cli("eval", "--gt", str(tmp_path / "gt.txt"), "--pred", str(tmp_path / "pred.txt"),
                     "--out", str(tmp_path / "eval"))
    assert result.returncode == 0, result.stderr
    assert "ATE RMSE" in result.stdout and (tmp_path / "eval" / "metrics.json").is_file()
