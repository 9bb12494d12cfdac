"""The camera height sets the metric scale and nothing else: the same drive at two heights gives the same rotations
and every length in the heights' ratio (real clip 06, validation data), for every method that has a scale of its
own; the speed prior's limit acts in proportion to the height too, and the run says how often it acted."""

import json
from pathlib import Path

import numpy as np
import pytest

from flowvo.cli import main


def run_at_height(real_clips: Path, out: Path, method: str, height_m: float) -> np.ndarray:
    assert main(["-q", "run", "--data", str(real_clips), "--sequence", "06", "--method", method, "--max-frames", "24",
                 "--camera-height", str(height_m), "--out", str(out)]) == 0
    return np.loadtxt(out / "06.txt").reshape(-1, 3, 4)


@pytest.mark.parametrize("method", ["flowvo", "flowvo-pair", "cnn", "classical"])
def test_every_length_follows_the_camera_height_exactly(real_clips, tmp_path, method):
    low = run_at_height(real_clips, tmp_path / "low", method, 1.3)
    high = run_at_height(real_clips, tmp_path / "high", method, 1.65)
    np.testing.assert_array_equal(low[:, :, :3], high[:, :, :3])
    assert np.linalg.norm(high[-1, :, 3]) > 5.0  # the car moved
    np.testing.assert_allclose(low[:, :, 3], high[:, :, 3] * (1.3 / 1.65), rtol=1e-6, atol=1e-9)


def test_the_run_records_the_speed_limit_in_proportion_to_the_height(real_clips, tmp_path):
    run_at_height(real_clips, tmp_path, "flowvo", 1.3)
    limit = json.loads((tmp_path / "run.json").read_text())["speed_limit"]
    assert limit["max_speed_mps"] == pytest.approx(45.0 * 1.3 / 1.65)
    assert limit["refused_measurements"] == 0  # 11.6 m/s on a straight road: nothing near the limit
