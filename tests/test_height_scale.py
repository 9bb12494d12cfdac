"""The camera height sets the metric scale and nothing else: the same drive at two heights gives the same rotations
and every length in the heights' ratio (real clip 06, validation data), for every method that has a scale of its
own; the speed prior's limit acts in proportion to the height too, and the run says how often it acted."""

import json
from pathlib import Path

import numpy as np
import pytest

from flowvo.cli import main
from flowvo.methods.flowvo import LOW_CAMERA_HEIGHT_M, MAX_SPEED_MPS
from flowvo.synth.dataset import synthesize
from flowvo.synth.synth_camera import SynthCamera


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
    assert limit["max_speed_mps"] == pytest.approx(MAX_SPEED_MPS * 1.3 / LOW_CAMERA_HEIGHT_M)
    assert limit["refused_measurements"] == 0  # 11.6 m/s on a straight road: nothing near the limit



def run_straight_drive_from_1_2_m(root: Path, positions_m: list[float]) -> tuple[Path, float]:
    """Render a straight drive through ``positions_m`` (metres along the road, one a frame at 10 Hz) seen from 1.2 m
    (620x188 at scale 0.4, suburban) and run the default method on it: its output folder and the path length (m)."""
    np.savetxt(root / "path.txt", [np.c_[np.eye(3), [0.0, 0.0, z]].ravel() for z in positions_m])
    synthesize(root / "data", ["00"], trajectory=root / "path.txt", scale=0.4, scene="suburban", workers=1,
               camera=SynthCamera(height_m=1.2))
    out = root / "run"
    assert main(["-q", "run", "--data", str(root / "data"), "--sequence", "00", "--out", str(out)]) == 0
    return out, float(np.linalg.norm(np.loadtxt(out / "00.txt")[-1, [3, 7, 11]]))


def test_a_camera_1_2_m_high_keeps_its_road_at_motorway_speed(tmp_path):
    """The speed limit, in proportion to the camera height, leaves a low camera its motorway. Set at 45 m/s for KITTI's
    1.65 m, it refused every road of a camera 1.2 m high above 32.7 m/s, and this drive read 151.6 m of 174.6 (22
    speeds refused): a straight drive seen from 1.2 m, pulling up from 18 to 41.6 m/s (150 km/h) in 6 s."""
    positions_m = np.cumsum([0.0] + [1.8 + 0.04 * i for i in range(59)])
    out, length_m = run_straight_drive_from_1_2_m(tmp_path, list(positions_m))
    assert json.loads((out / "run.json").read_text())["speed_limit"]["refused_measurements"] == 0
    assert length_m == pytest.approx(positions_m[-1], rel=0.02)  # 176.3 of 174.6 m


def test_a_camera_1_2_m_high_starting_at_motorway_speed_measures_its_road_from_the_start(tmp_path):
    """A drive seen from 1.2 m that starts at 36 m/s: its road moves beyond DIS's reach before any prediction exists
    (49.5 KITTI camera heights a second), so its first road is found through the best of the predictions at many
    step lengths. Before, its first 20 steps measured nothing and the path read 182.7 m of 212.4."""
    out, length_m = run_straight_drive_from_1_2_m(tmp_path, [3.6 * i for i in range(60)])
    steps = np.genfromtxt(out / "00_steps.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert "none" not in set(steps["measured_by"])  # 212.9 m
    assert length_m == pytest.approx(3.6 * 59, rel=0.02)
