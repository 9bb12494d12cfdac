import numpy as np
import pytest

from flowvo import geometry as g
from flowvo.metrics.trajectory_errors import ate_rmse_m, rpe, umeyama_alignment
from flowvo.trajectory import Trajectory


def random_trajectory(seed: int, n: int = 40) -> Trajectory:
    rng = np.random.default_rng(seed)
    return Trajectory.from_poses(g.chain_se3(g.se3_from_targets(rng.normal(scale=0.3, size=(n - 1, 6)))))


def test_umeyama_recovers_similarity_transform():
    rng = np.random.default_rng(3)
    points = rng.normal(size=(30, 3))
    R = g.so3_exp(np.array([0.2, -0.5, 0.3]))
    moved = 2.5 * points @ R.T + np.array([1.0, -2.0, 3.0])
    R_est, t_est, s_est = umeyama_alignment(points, moved, with_scale=True)
    np.testing.assert_allclose(R_est, R, atol=1e-10)
    np.testing.assert_allclose(t_est, [1.0, -2.0, 3.0], atol=1e-10)
    assert s_est == pytest.approx(2.5)


def test_ate_is_zero_for_a_rigidly_moved_copy_under_every_alignment():
    gt = random_trajectory(4)
    offset = g.se3_from_targets(np.array([[5.0, 1.0, -2.0, 0.1, 0.4, -0.2]]))[0]
    moved = Trajectory(gt.frame_ids, offset @ gt.T_world_cam)
    for alignment in ("none", "6dof", "7dof"):
        assert ate_rmse_m(gt, moved, alignment) == pytest.approx(0.0, abs=1e-9)


def test_ate_7dof_removes_scale_but_6dof_does_not():
    gt = random_trajectory(5)
    scaled = gt.T_world_cam.copy()
    scaled[:, :3, 3] *= 0.5
    pred = Trajectory(gt.frame_ids, scaled)
    assert ate_rmse_m(gt, pred, "7dof") == pytest.approx(0.0, abs=1e-9)
    assert ate_rmse_m(gt, pred, "6dof") > 0.1


def test_rpe_of_constant_offset_per_step():
    gt = Trajectory.from_poses(g.chain_se3(np.tile(np.eye(4), (10, 1, 1)) + np.pad(np.eye(3, 4, 3), ((0, 1), (0, 0)))))
    pred_poses = gt.T_world_cam.copy()
    pred_poses[:, 2, 3] += 0.1 * np.arange(11)
    result = rpe(gt, Trajectory(gt.frame_ids, pred_poses))
    assert result["rpe_trans_rmse_m"] == pytest.approx(0.1)
    assert result["rpe_rot_rmse_deg"] == pytest.approx(0.0, abs=1e-6)
